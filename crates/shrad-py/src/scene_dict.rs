//! `shrad.load_dict({...})`: a scene file's content as a Python dict with numpy meshes.
//! The dict becomes the TOML reader's own definitions (`shrad::scene::scene_def`): each
//! part is converted into a value tree and deserialized by the same serde types, and the
//! same `SceneBuilder` checks it and makes the objects, so the two syntaxes take the same
//! keys and refuse the same mistakes with the same words. Only what a TOML file cannot
//! hold stays here: `name`, the `objects` list, and the numpy arrays `positions`,
//! `triangles` and `colors`, read in bulk into the definition's mesh data (a `transform`
//! array is a 4x4 list like any other value).

use std::path::Path;
use std::sync::Arc;

use numpy::{AllowTypeChange, PyArrayLike2};
use pyo3::exceptions::PyValueError;
use pyo3::prelude::*;
use pyo3::types::{PyBool, PyDict, PyFloat, PyInt, PyList, PyString, PyTuple};
use shrad::scene::scene_def::{
    from_value, CameraDef, EnvironmentDef, LightDef, ObjectDef, SceneBuilder, SettingsDef, Table,
    Value,
};
use shrad::scene::Mesh;

use crate::arrays;
use crate::scene::{sizing, PyScene};

/// Build a scene from a dict, with the keys of a TOML scene file (docs/scene-format.md)
/// and meshes as numpy arrays:
///
/// ```python
/// shrad.load_dict({
///     "name": "two boxes",                         # for messages (default "<dict>")
///     "camera": {"eye": [0, 1, -3], "target": [0, 1, 0], "yfov_deg": 40},
///     "settings": {"patches": 4000},               # or "patch_size": 0.05
///     "environment": {"radiance": [0.5, 0.6, 0.8]}, # or "file": "sky.exr",
///                                                   # "rotate_deg": 90, "scale": 2
///     "objects": [
///         {"name": "room", "shape": "box", "size": [4, 3, 4], "inward": True,
///          "role": "boundary", "reflectance": [0.7, 0.7, 0.7]},
///         {"name": "lamp", "shape": "quad", "corners": [[-.5, 2.99, -.5], [.5, 2.99, -.5],
///          [.5, 2.99, .5], [-.5, 2.99, .5]], "emission": [10, 10, 10]},
///         {"name": "blob", "shape": "mesh", "positions": P, "triangles": T,   # (N,3), (M,3)
///          "colors": C,                              # optional (N,3) linear vertex colours
///          "position": [0, 0.5, 0], "rotation_deg": [0, 30, 0], "scale": 0.5,
///          # or "transform": a 4x4 matrix
///          "key": [{"time": 0, "translation": [0, 0, 0]},
///                  {"time": 2, "translation": [1, 0, 0], "rotation_deg": [0, 90, 0]}],
///          "emission_key": [{"time": 0, "emission": [0, 0, 0]}],
///          "interpolation": "linear"},               # or "step"
///     ],
///     "lights": [                                   # punctual lights, as [[lights]]
///         {"kind": "point", "position": [0, 2, 0], "power": 100},
///         {"kind": "spot", "position": [0, 2.9, 0], "direction": [0, -1, 0],
///          "power": 500, "outer_cone_deg": 40, "blend": 0.2},
///     ],
/// })
/// ```
///
/// Shapes: `quad` (`corners`: 4 points, counter-clockwise seen from the front), `box`
/// (`size`, `inward`), `sphere` (`radius`, `segments`), `mesh` (`positions`, `triangles`,
/// optional `colors`; or `file`: a glTF / OBJ / TOML file relative to the working
/// directory, filtered by `node` / `mesh`). Missing roles are inferred as for files. An
/// unknown key, a wrong shape or a bad value raises `ValueError` naming the object and the
/// key. Solver settings go to `shrad.Engine`, not into `settings`.
#[pyfunction]
#[pyo3(signature = (definition, *, patches=None, patch_size=None))]
pub fn load_dict(
    definition: &Bound<'_, PyDict>,
    patches: Option<i64>,
    patch_size: Option<f32>,
) -> PyResult<PyScene> {
    let source: String = match definition.get_item("name")? {
        Some(n) => n.extract().map_err(|_| {
            pyo3::exceptions::PyTypeError::new_err(format!(
                "the scene's 'name' must be a string, got {}",
                n.repr().map_or_else(|_| "?".into(), |r| r.to_string())
            ))
        })?,
        None => "<dict>".to_string(),
    };
    let fail = |m: String| PyValueError::new_err(format!("{source}: {m}"));
    check_keys(
        definition,
        &[
            "name",
            "camera",
            "settings",
            "environment",
            "objects",
            "lights",
        ],
        "the scene",
    )
    .map_err(fail)?;
    // A file the dict names that cannot be read is an `OSError` naming it, as `load` gives.
    let mut builder = SceneBuilder::new(&source, Path::new(""));
    let mut scene = match build(definition, &mut builder) {
        Ok(()) => builder.finish(),
        Err(m) => {
            let e = builder.error(Path::new(&source), m);
            return Err(crate::to_py_err(e.into()));
        }
    };
    // As `load` finishes a scene file (a dict's reflectance of 1 was refused, a file's
    // read as 0.999).
    shrad::scene::infer_roles(&mut scene);
    shrad::scene::warn_faces_turned_away(&mut scene);
    shrad::scene::clamp_reflectance(&mut scene);
    scene
        .validate(Path::new(&source), false)
        .map_err(|e| crate::to_py_err(e.into()))?;
    let sizing = sizing(&scene, patches, patch_size)?;
    Ok(PyScene {
        scene: Arc::new(scene),
        sizing,
    })
}

/// The dict's settings, camera, objects and lights through the scene definition's `builder`
/// (files named in the dict are found from the working directory, as Python opens files).
fn build(definition: &Bound<'_, PyDict>, builder: &mut SceneBuilder) -> Result<(), String> {
    if let Some(s) = present(definition, "settings")? {
        let at = |m: String| format!("settings: {m}");
        let def: SettingsDef = from_value(to_value(&s).map_err(at)?).map_err(at)?;
        if !def.solver.is_empty() {
            return Err(at(
                "'solver' is read by the command line only; give solver settings to shrad.Engine(scene, solver, preset, **settings)".into(),
            ));
        }
        builder.settings(def).map_err(at)?;
    }
    if let Some(c) = present(definition, "camera")? {
        let at = |m: String| format!("camera: {m}");
        let def: CameraDef = from_value(to_value(&c).map_err(at)?).map_err(at)?;
        builder.camera(&def).map_err(at)?;
    }
    if let Some(e) = present(definition, "environment")? {
        let at = |m: String| format!("environment: {m}");
        let def: EnvironmentDef = from_value(to_value(&e).map_err(at)?).map_err(at)?;
        builder.environment(&def).map_err(at)?;
    }
    let objects = present(definition, "objects")?.ok_or("no 'objects' (a list of dicts)")?;
    let objects = objects
        .cast_into::<PyList>()
        .map_err(|_| "'objects' must be a list of dicts".to_string())?;
    for (i, o) in objects.iter().enumerate() {
        let o = o
            .cast_into::<PyDict>()
            .map_err(|_| format!("object {i} must be a dict"))?;
        let name = o
            .get_item("name")
            .ok()
            .flatten()
            .and_then(|n| n.extract::<String>().ok())
            .unwrap_or_else(|| format!("object{i}"));
        let at = |m: String| format!("object {i} '{name}': {m}");
        let def = object_def(&o).map_err(at)?;
        builder.object(i, def).map_err(at)?;
    }
    if let Some(lights) = present(definition, "lights")? {
        let lights = lights
            .cast_into::<PyList>()
            .map_err(|_| "'lights' must be a list of dicts".to_string())?;
        for (i, l) in lights.iter().enumerate() {
            let at = |m: String| format!("lights {i}: {m}");
            let def: LightDef = from_value(to_value(&l).map_err(at)?).map_err(at)?;
            builder.light(i, &def).map_err(at)?;
        }
    }
    Ok(())
}

/// The sky `Engine.set_sky` takes: a uniform `radiance` or a map `file`; neither, none.
pub fn environment(
    radiance: Option<[f32; 3]>,
    file: Option<std::path::PathBuf>,
    rotate_deg: f32,
    scale: f32,
) -> PyResult<Option<shrad::scene::Environment>> {
    use shrad::scene::{EnvMap, Environment};
    let mut env = match (radiance, file) {
        (Some(_), Some(_)) => return Err(PyValueError::new_err("give radiance or file, not both")),
        (None, None) => return Ok(None),
        (Some(r), None) => Environment::uniform(r.into()),
        (None, Some(f)) => {
            Environment::from_map(EnvMap::load(&f).map_err(|e| crate::to_py_err(e.into()))?)
        }
    };
    env.rotate_deg = rotate_deg;
    env.scale = scale;
    Ok(Some(env))
}

/// `d[key]` unless absent or `None`.
fn present<'py>(d: &Bound<'py, PyDict>, key: &str) -> Result<Option<Bound<'py, PyAny>>, String> {
    Ok(d.get_item(key)
        .map_err(|e| e.to_string())?
        .filter(|v| !v.is_none()))
}

/// An error for any key of `d` not in `known`, with the keys that are.
fn check_keys(d: &Bound<'_, PyDict>, known: &[&str], what: &str) -> Result<(), String> {
    for k in d.keys() {
        let k: String = k
            .extract()
            .map_err(|_| format!("{what}: keys must be strings, got {k}"))?;
        if !known.contains(&k.as_str()) {
            return Err(format!(
                "{what}: unknown key '{k}' (known: {})",
                known.join(", ")
            ));
        }
    }
    Ok(())
}

/// The numpy keys, read as mesh data rather than as values.
const MESH_ARRAYS: [&str; 3] = ["positions", "triangles", "colors"];

/// One entry of `objects` as the scene definition's object.
fn object_def(d: &Bound<'_, PyDict>) -> Result<ObjectDef, String> {
    let rest = PyDict::new(d.py());
    for (k, v) in d.iter() {
        let is_array = k
            .extract::<String>()
            .is_ok_and(|k| MESH_ARRAYS.contains(&k.as_str()));
        if !is_array {
            rest.set_item(k, v).map_err(|e| e.to_string())?;
        }
    }
    let mut def: ObjectDef = from_value(to_value(rest.as_any())?)?;
    def.mesh_data = mesh_data(d)?;
    Ok(def)
}

/// Deepest nesting converted (a dict that holds itself would never end).
const MAX_NESTING: usize = 32;

/// A Python value as a definition value: numbers, strings, booleans, lists, tuples, dicts
/// with string keys (a `None` entry is left out, as if absent), paths, and numpy arrays
/// and scalars (through `tolist`). The error names the key path (`key[0].time: ...`).
fn to_value(v: &Bound<'_, PyAny>) -> Result<Value, String> {
    convert(v, 0).map_err(|(path, m)| {
        if path.is_empty() {
            m
        } else {
            format!("{path}: {m}")
        }
    })
}

/// [`to_value`]'s work; the error is (key path, message).
fn convert(v: &Bound<'_, PyAny>, depth: usize) -> Result<Value, (String, String)> {
    let here = |m: String| (String::new(), m);
    if depth > MAX_NESTING {
        return Err(here(format!("nested more than {MAX_NESTING} deep")));
    }
    // bool before int: Python's bool is an int.
    if let Ok(b) = v.cast::<PyBool>() {
        return Ok(Value::Boolean(b.is_true()));
    }
    if let Ok(i) = v.cast::<PyInt>() {
        return i
            .extract::<i64>()
            .map(Value::Integer)
            .map_err(|_| here(format!("integer {i} is out of range")));
    }
    if let Ok(f) = v.cast::<PyFloat>() {
        return Ok(Value::Float(f.value()));
    }
    if let Ok(s) = v.cast::<PyString>() {
        return Ok(Value::String(s.to_string()));
    }
    if let Ok(d) = v.cast::<PyDict>() {
        return table(d, depth);
    }
    if v.is_instance_of::<PyList>() || v.is_instance_of::<PyTuple>() {
        let mut items = Vec::new();
        for (i, item) in v.try_iter().map_err(|e| here(e.to_string()))?.enumerate() {
            let item = item.map_err(|e| here(e.to_string()))?;
            let value = convert(&item, depth + 1).map_err(|(p, m)| (format!("[{i}]{p}"), m))?;
            items.push(value);
        }
        return Ok(Value::Array(items));
    }
    if v.hasattr("__fspath__").unwrap_or(false) {
        let p: std::path::PathBuf = v.extract().map_err(|e: PyErr| here(e.to_string()))?;
        return Ok(Value::String(p.to_string_lossy().into_owned()));
    }
    if v.hasattr("tolist").unwrap_or(false) {
        let plain = v.call_method0("tolist").map_err(|e| here(e.to_string()))?;
        return convert(&plain, depth + 1);
    }
    let ty = v
        .get_type()
        .name()
        .map_or_else(|_| "?".to_string(), |n| n.to_string());
    Err(here(format!(
        "a {ty} is not a number, string, list or dict"
    )))
}

fn table(d: &Bound<'_, PyDict>, depth: usize) -> Result<Value, (String, String)> {
    let mut t = Table::new();
    for (k, v) in d.iter() {
        let k: String = k
            .extract()
            .map_err(|_| (String::new(), format!("keys must be strings, got {k}")))?;
        if v.is_none() {
            continue;
        }
        let value = convert(&v, depth + 1).map_err(|(p, m)| {
            let sep = if p.is_empty() || p.starts_with('[') {
                ""
            } else {
                "."
            };
            (format!("{k}{sep}{p}"), m)
        })?;
        t.insert(k, value);
    }
    Ok(Value::Table(t))
}

/// `positions`, `triangles` and `colors` as a mesh, when given.
fn mesh_data(d: &Bound<'_, PyDict>) -> Result<Option<Mesh>, String> {
    let [positions, triangles, colors] = MESH_ARRAYS.map(|k| present(d, k));
    let (positions, triangles, colors) = (positions?, triangles?, colors?);
    let (positions, triangles) = match (positions, triangles) {
        (None, None) if colors.is_none() => return Ok(None),
        (Some(p), Some(t)) => (p, t),
        (None, _) => return Err("mesh data needs 'positions' (N, 3)".into()),
        (Some(_), None) => return Err("mesh data needs 'triangles' (M, 3)".into()),
    };
    let positions = vec3s(&positions, "positions")?;
    let triangles = table_of(&triangles, "triangles", "iu")?;
    let unsigned64 = triangles
        .getattr("dtype")
        .and_then(|d| d.getattr("str"))
        .is_ok_and(|s| s.to_string().ends_with("u8"));
    let message = |e: PyErr| e.value(d.py()).to_string();
    let triangles = if unsigned64 {
        // uint64 indices read as they are (as int64 the largest would wrap to negatives).
        let t: PyArrayLike2<'_, u64, AllowTypeChange> = triangles.extract().map_err(message)?;
        arrays::read_triangles(&t, positions.len(), "'triangles'")
    } else {
        let t: PyArrayLike2<'_, i64, AllowTypeChange> = triangles.extract().map_err(message)?;
        arrays::read_triangles(&t, positions.len(), "'triangles'")
    }
    .map_err(message)?;
    let mut mesh = Mesh::new(positions, triangles);
    if let Some(colors) = colors {
        let colors = vec3s(&colors, "colors")?;
        if colors.len() != mesh.positions.len() {
            return Err(format!(
                "'colors' has {} rows for {} positions",
                colors.len(),
                mesh.positions.len()
            ));
        }
        if colors
            .iter()
            .any(|c| !c.is_finite() || c.min_element() < 0.0)
        {
            return Err("'colors' must be finite and >= 0".into());
        }
        mesh.colors = colors;
    }
    Ok(Some(mesh))
}

/// An `(N, 3)` array of numbers named `what`.
fn vec3s(a: &Bound<'_, PyAny>, what: &str) -> Result<Vec<glam::Vec3>, String> {
    let a: PyArrayLike2<'_, f32, AllowTypeChange> = table_of(a, what, "iuf")?
        .extract()
        .map_err(|e: PyErr| e.value(a.py()).to_string())?;
    arrays::read_vec3s(&a, &format!("'{what}'")).map_err(|e| e.value(a.py()).to_string())
}

/// `a` as a numpy array of rows of 3, checked before any conversion: its shape, and its
/// dtype's kind among `kinds` (numpy's letters: `i` signed and `u` unsigned integers, `f`
/// floats), so that float indices are not truncated nor complex numbers cut to their real
/// part without a word.
fn table_of<'py>(
    a: &Bound<'py, PyAny>,
    what: &str,
    kinds: &str,
) -> Result<Bound<'py, PyAny>, String> {
    let rows = if kinds.contains('f') { "N" } else { "M" };
    let kind = if kinds.contains('f') {
        "numbers"
    } else {
        "integers"
    };
    let fail = |m: String| format!("'{what}' must be an ({rows}, 3) array of {kind}: {m}");
    let array = a
        .py()
        .import("numpy")
        .and_then(|np| np.call_method1("asarray", (arrays::aligned(a)?,)))
        .map_err(|e| fail(e.value(a.py()).to_string()))?;
    let shape: Vec<usize> = array
        .getattr("shape")
        .and_then(|s| s.extract())
        .map_err(|e| fail(e.to_string()))?;
    if shape.len() != 2 || shape[1] != 3 {
        return Err(fail(format!("got shape {shape:?}")));
    }
    let dtype = array.getattr("dtype").map_err(|e| fail(e.to_string()))?;
    let k: String = dtype
        .getattr("kind")
        .and_then(|k| k.extract())
        .map_err(|e| fail(e.to_string()))?;
    if !kinds.contains(k.as_str()) {
        return Err(fail(format!("got dtype {dtype}")));
    }
    Ok(array)
}
