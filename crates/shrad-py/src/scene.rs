//! Scenes: `shrad.load(path_or_builtin, ...)` (every format the CLI reads) and
//! `shrad.load_dict({...})`, a scene file's content as a Python dict with numpy meshes
//! (the keys are those of docs/scene-format.md); `Scene.objects` lists names, roles and
//! bounds.

use std::path::Path;
use std::sync::Arc;

use glam::{Affine3A, Quat, Vec3};
use numpy::{AllowTypeChange, PyArrayLike2};
use pyo3::exceptions::PyValueError;
use pyo3::prelude::*;
use pyo3::types::{PyDict, PyList};
use shrad::scene::{
    Aabb, Animation, Camera, EmissionKey, Keyframe, LoadOptions, Material, Mesh, Object, Role,
    Scene,
};
use shrad::PatchSizing;

use crate::arrays;

/// A loaded scene and how it is to be cut into patches. Immutable: an engine made from it
/// takes its own copy, so one scene can feed many engines.
#[pyclass(name = "Scene", module = "shrad", frozen)]
pub struct PyScene {
    pub scene: Arc<Scene>,
    pub sizing: PatchSizing,
}

/// One object of a scene: name, role (`"boundary"`, `"interior"` or `"light"`), world
/// bounds at rest, triangle count, and whether it is animated.
#[pyclass(name = "ObjectInfo", module = "shrad", frozen, get_all)]
pub struct PyObjectInfo {
    /// Index in `Scene.objects` (what `Engine.set_transform(3, ...)` takes).
    pub index: usize,
    /// The object's name (what `Engine.set_transform("box", ...)` takes).
    pub name: String,
    /// `"boundary"`, `"interior"` or `"light"`.
    pub role: String,
    /// World bounding box at rest: `((x0, y0, z0), (x1, y1, z1))`.
    pub bounds: ([f32; 3], [f32; 3]),
    /// Triangles of its mesh.
    pub triangles: usize,
    /// Does it move or change emission over time?
    pub animated: bool,
}

#[pymethods]
impl PyObjectInfo {
    fn __repr__(&self) -> String {
        format!(
            "ObjectInfo(index={}, name={:?}, role={:?}, bounds={:?}, triangles={}, animated={})",
            self.index,
            self.name,
            self.role,
            self.bounds,
            self.triangles,
            if self.animated { "True" } else { "False" }
        )
    }
}

#[pymethods]
impl PyScene {
    /// Where the scene came from (a path, `builtin:NAME` or the dict's `name`).
    #[getter]
    fn source(&self) -> String {
        self.scene.source.clone()
    }

    /// The objects, in order (an object's index is its position here).
    #[getter]
    fn objects(&self) -> Vec<PyObjectInfo> {
        self.object_list()
    }

    /// World bounding box of the whole scene at rest.
    #[getter]
    fn bounds(&self) -> ([f32; 3], [f32; 3]) {
        let b = self
            .scene
            .bounds()
            .unwrap_or(Aabb::new(Vec3::ZERO, Vec3::ZERO));
        (b.min.to_array(), b.max.to_array())
    }

    /// Length of the scene's animation in seconds (0 when static).
    #[getter]
    fn duration(&self) -> f32 {
        self.scene.duration()
    }

    /// Non-fatal problems found while loading (the CLI prints them as warnings).
    #[getter]
    fn warnings(&self) -> Vec<String> {
        self.scene.warnings.clone()
    }

    /// How the scene is cut: `("count", n)` patches in all, or `("size", h)` per edge.
    #[getter]
    fn patching(&self) -> (String, f64) {
        match self.sizing {
            PatchSizing::Count(n) => ("count".into(), n as f64),
            PatchSizing::Size(h) => ("size".into(), h as f64),
        }
    }

    /// The same scene cut differently.
    #[pyo3(signature = (patches=None, patch_size=None))]
    fn with_patches(&self, patches: Option<usize>, patch_size: Option<f32>) -> PyResult<PyScene> {
        Ok(PyScene {
            scene: self.scene.clone(),
            sizing: sizing(&self.scene, patches, patch_size)?,
        })
    }

    fn __len__(&self) -> usize {
        self.scene.objects.len()
    }

    fn __repr__(&self) -> String {
        let (kind, n) = self.patching();
        format!(
            "Scene({:?}, {} objects, patches {kind} {n})",
            self.scene.source,
            self.scene.objects.len()
        )
    }
}

impl PyScene {
    /// [`Scene.objects`](PyScene::objects).
    pub fn object_list(&self) -> Vec<PyObjectInfo> {
        self.scene
            .objects
            .iter()
            .enumerate()
            .map(|(index, o)| {
                let Aabb { min: lo, max: hi } = o
                    .world_bounds()
                    .unwrap_or(Aabb::new(Vec3::ZERO, Vec3::ZERO));
                PyObjectInfo {
                    index,
                    name: o.name.clone(),
                    role: o.role().name().to_string(),
                    bounds: (lo.to_array(), hi.to_array()),
                    triangles: o.mesh.triangles.len(),
                    animated: o.is_animated(),
                }
            })
            .collect()
    }
}

/// Patch sizing as the CLI chooses it: `patch_size` wins, then `patches`, then the scene
/// file's settings, then 20,000 patches.
pub fn sizing(
    scene: &Scene,
    patches: Option<usize>,
    patch_size: Option<f32>,
) -> PyResult<PatchSizing> {
    if let Some(h) = patch_size {
        if !(h.is_finite() && h > 0.0) {
            return Err(PyValueError::new_err(format!(
                "patch_size must be a positive number, got {h}"
            )));
        }
        return Ok(PatchSizing::Size(h));
    }
    if let Some(n) = patches {
        if n == 0 || n > 50_000_000 {
            return Err(PyValueError::new_err(format!(
                "patches must be between 1 and 50000000, got {n}"
            )));
        }
        return Ok(PatchSizing::Count(n));
    }
    Ok(match (scene.settings.patch_size, scene.settings.patches) {
        (Some(h), _) => PatchSizing::Size(h),
        (None, Some(n)) => PatchSizing::Count(n),
        (None, None) => PatchSizing::Count(20_000),
    })
}

/// Load a scene: a `.gltf` / `.glb`, `.obj` or `.toml` scene file, or a built-in name
/// (`"cornell"`, `"room"`; see `shrad.builtins()`).
///
/// `patches` (a total count) or `patch_size` (an edge length in scene units) say how it is
/// cut; neither: the scene file's settings, else 20,000 patches. `animation` plays one glTF
/// animation by name or index (default: all of them). `drop_degenerate` drops zero-area
/// triangles instead of failing. Raises `OSError` when the file cannot be read and
/// `ValueError` when its content is wrong, with the file named.
#[pyfunction]
#[pyo3(signature = (path, *, patches=None, patch_size=None, animation=None, drop_degenerate=false))]
pub fn load(
    py: Python<'_>,
    path: std::path::PathBuf,
    patches: Option<usize>,
    patch_size: Option<f32>,
    animation: Option<String>,
    drop_degenerate: bool,
) -> PyResult<PyScene> {
    let opts = LoadOptions {
        drop_degenerate,
        animation,
    };
    let scene = py
        .detach(|| shrad::scene::load(&path, &opts))
        .map_err(|e| crate::to_py_err(e.into()))?;
    let sizing = sizing(&scene, patches, patch_size)?;
    Ok(PyScene {
        scene: Arc::new(scene),
        sizing,
    })
}

/// The names `shrad.load` takes as built-in scenes.
#[pyfunction]
pub fn builtins() -> Vec<&'static str> {
    shrad::scene::builtin_names().to_vec()
}

/// Build a scene from a dict, with the keys of a TOML scene file (docs/scene-format.md)
/// and meshes as numpy arrays:
///
/// ```python
/// shrad.load_dict({
///     "name": "two boxes",                         # for messages (default "<dict>")
///     "camera": {"eye": [0, 1, -3], "target": [0, 1, 0], "yfov_deg": 40},
///     "settings": {"patches": 4000},               # or "patch_size": 0.05
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
/// })
/// ```
///
/// Shapes: `quad` (`corners`: 4 points, counter-clockwise seen from the front), `box`
/// (`size`, `inward`), `mesh` (`positions`, `triangles`, optional `colors`; or `file`: a
/// glTF / OBJ / TOML file whose objects are taken whole). Missing roles are inferred as
/// for files. An unknown key, a wrong shape or a bad value raises `ValueError` naming the
/// object and the key.
#[pyfunction]
#[pyo3(signature = (definition, *, patches=None, patch_size=None))]
pub fn load_dict(
    definition: &Bound<'_, PyDict>,
    patches: Option<usize>,
    patch_size: Option<f32>,
) -> PyResult<PyScene> {
    let source: String = match definition.get_item("name")? {
        Some(n) => n.extract()?,
        None => "<dict>".to_string(),
    };
    let fail = |m: String| PyValueError::new_err(format!("{source}: {m}"));
    check_keys(
        definition,
        &["name", "camera", "settings", "objects"],
        "the scene",
    )
    .map_err(fail)?;
    let mut scene = Scene {
        source: source.clone(),
        ..Default::default()
    };
    if let Some(s) = definition.get_item("settings")? {
        let s = s
            .cast_into::<PyDict>()
            .map_err(|_| fail("'settings' must be a dict".into()))?;
        check_keys(&s, &["patches", "patch_size"], "settings").map_err(fail)?;
        scene.settings.patches = get(&s, "patches").map_err(fail)?;
        scene.settings.patch_size = get(&s, "patch_size").map_err(fail)?;
    }
    if let Some(c) = definition.get_item("camera")? {
        let c = c
            .cast_into::<PyDict>()
            .map_err(|_| fail("'camera' must be a dict".into()))?;
        check_keys(&c, &["eye", "target", "yfov_deg", "aspect_ratio"], "camera").map_err(fail)?;
        scene.camera = Some(camera(&c).map_err(|m| fail(format!("camera: {m}")))?);
    }
    let objects = definition
        .get_item("objects")?
        .ok_or_else(|| fail("no 'objects' (a list of dicts)".into()))?;
    let objects = objects
        .cast_into::<PyList>()
        .map_err(|_| fail("'objects' must be a list of dicts".into()))?;
    for (i, o) in objects.iter().enumerate() {
        let o = o
            .cast_into::<PyDict>()
            .map_err(|_| fail(format!("object {i} must be a dict")))?;
        let name: Option<String> = get(&o, "name").map_err(fail)?;
        let name = name.unwrap_or_else(|| format!("object{i}"));
        let made = object(&o, &name, &mut scene.warnings)
            .map_err(|m| fail(format!("object {i} '{name}': {m}")))?;
        scene.objects.extend(made);
    }
    shrad::scene::infer_roles(&mut scene);
    scene
        .validate(Path::new(&source), false)
        .map_err(|e| crate::to_py_err(e.into()))?;
    let sizing = sizing(&scene, patches, patch_size)?;
    Ok(PyScene {
        scene: Arc::new(scene),
        sizing,
    })
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

/// `d[key]` as `T` when present; an error naming the key when it has the wrong type.
fn get<'py, T: FromPyObjectOwned<'py>>(
    d: &Bound<'py, PyDict>,
    key: &str,
) -> Result<Option<T>, String> {
    match d.get_item(key).map_err(|e| e.to_string())? {
        None => Ok(None),
        Some(v) if v.is_none() => Ok(None),
        Some(v) => v.extract::<T>().map(Some).map_err(|_| {
            let ty = v
                .get_type()
                .name()
                .map_or_else(|_| "?".to_string(), |n| n.to_string());
            format!("'{key}' has the wrong type ({ty}: {})", short_repr(&v))
        }),
    }
}

fn short_repr(v: &Bound<'_, PyAny>) -> String {
    let r = v.repr().map_or_else(|_| "?".to_string(), |r| r.to_string());
    if r.chars().count() > 60 {
        format!("{}...", r.chars().take(60).collect::<String>())
    } else {
        r
    }
}

fn finite3(v: [f32; 3], what: &str) -> Result<Vec3, String> {
    let v = Vec3::from(v);
    if !v.is_finite() {
        return Err(format!("'{what}' must be finite, got {v}"));
    }
    Ok(v)
}

/// `rotation_deg` (about X, then Y, then Z: R = Rz Ry Rx, as in scene files) or
/// `rotation_quat` (`[x, y, z, w]`).
fn rotation(d: &Bound<'_, PyDict>) -> Result<Quat, String> {
    let deg: Option<[f32; 3]> = get(d, "rotation_deg")?;
    let quat: Option<[f32; 4]> = get(d, "rotation_quat")?;
    match (deg, quat) {
        (Some(_), Some(_)) => Err("give rotation_deg or rotation_quat, not both".into()),
        (Some(r), None) => {
            let r = finite3(r, "rotation_deg")?;
            Ok(Quat::from_rotation_z(r.z.to_radians())
                * Quat::from_rotation_y(r.y.to_radians())
                * Quat::from_rotation_x(r.x.to_radians()))
        }
        (None, Some(q)) => {
            let q = Quat::from_array(q);
            if !q.is_finite() || q.length() < 1e-6 {
                return Err(format!("rotation_quat {q} must be finite and non-zero"));
            }
            Ok(q.normalize())
        }
        (None, None) => Ok(Quat::IDENTITY),
    }
}

fn camera(c: &Bound<'_, PyDict>) -> Result<Camera, String> {
    let eye = finite3(get(c, "eye")?.ok_or("needs 'eye' = [x, y, z]")?, "eye")?;
    let target = finite3(
        get(c, "target")?.ok_or("needs 'target' = [x, y, z]")?,
        "target",
    )?;
    let yfov: f32 = get(c, "yfov_deg")?.unwrap_or(40.0);
    if !(yfov > 0.0 && yfov < 180.0) {
        return Err(format!("yfov_deg {yfov} must be between 0 and 180"));
    }
    if (eye - target).length() < 1e-9 {
        return Err("eye and target are the same point".into());
    }
    let mut cam = Camera::look_at(eye, target, yfov.to_radians());
    cam.aspect_ratio = get(c, "aspect_ratio")?;
    Ok(cam)
}

const OBJECT_KEYS: &[&str] = &[
    "name",
    "role",
    "shape",
    "corners",
    "size",
    "inward",
    "positions",
    "triangles",
    "colors",
    "file",
    "reflectance",
    "emission",
    "double_sided",
    "position",
    "rotation_deg",
    "rotation_quat",
    "scale",
    "transform",
    "patch_size",
    "interpolation",
    "key",
    "emission_key",
];

/// One entry of `objects` (a `mesh` with a `file` may give several objects).
fn object(
    d: &Bound<'_, PyDict>,
    name: &str,
    warnings: &mut Vec<String>,
) -> Result<Vec<Object>, String> {
    check_keys(d, OBJECT_KEYS, "keys")?;
    let shape: String = get(d, "shape")?.ok_or("needs 'shape' (quad, box or mesh)")?;
    let only = |keys: &[&str], shape: &str| -> Result<(), String> {
        for k in keys {
            if d.contains(*k).unwrap_or(false) {
                return Err(format!("'{k}' does not apply to shape '{shape}'"));
            }
        }
        Ok(())
    };
    let role = match get::<String>(d, "role")?.as_deref() {
        None => None,
        Some("boundary") => Some(Role::Boundary),
        Some("interior") => Some(Role::Interior),
        Some("light") => Some(Role::Light),
        Some(r) => return Err(format!("role '{r}' is not boundary, interior or light")),
    };
    let reflectance = get::<[f32; 3]>(d, "reflectance")?
        .map(|r| finite3(r, "reflectance"))
        .transpose()?;
    if reflectance.is_some_and(|r| r.min_element() < 0.0) {
        return Err("reflectance must be >= 0".into());
    }
    let emission = get::<[f32; 3]>(d, "emission")?
        .map(|e| finite3(e, "emission"))
        .transpose()?;
    if emission.is_some_and(|e| e.min_element() < 0.0) {
        return Err("emission must be >= 0".into());
    }
    let rest = rest_transform(d)?;
    let patch_size: Option<f32> = get(d, "patch_size")?;
    if patch_size.is_some_and(|h| !(h > 0.0 && h.is_finite())) {
        return Err("patch_size must be positive".into());
    }
    let animation = animation(d)?;
    let mut material = Material {
        reflectance: reflectance.unwrap_or(Material::default().reflectance),
        emitted_radiance: emission.unwrap_or(Vec3::ZERO),
        double_sided: get(d, "double_sided")?.unwrap_or(false),
        base_color_texture: None,
        emissive_texture: None,
    };
    if emission.is_none() {
        if let Some(e) = animation
            .as_ref()
            .and_then(|a| a.emission_at(f32::NEG_INFINITY))
        {
            material.emitted_radiance = e;
        }
    }
    let make = |mesh: Mesh, material: Material| {
        let mut o = Object::new(name, mesh, material);
        o.role = role;
        o.world_from_object = rest;
        o.animation = animation.clone();
        o.patch_size = patch_size;
        o
    };
    match shape.as_str() {
        "quad" => {
            only(
                &["size", "inward", "positions", "triangles", "colors", "file"],
                "quad",
            )?;
            let c: Vec<[f32; 3]> =
                get(d, "corners")?.ok_or("shape 'quad' needs 'corners' (4 points)")?;
            let c: [[f32; 3]; 4] = c
                .as_slice()
                .try_into()
                .map_err(|_| format!("'corners' must have 4 points, not {}", c.len()))?;
            let c = c.map(Vec3::from);
            Ok(vec![make(shrad::scene::quad(c), material)])
        }
        "box" => {
            only(
                &["corners", "positions", "triangles", "colors", "file"],
                "box",
            )?;
            let size = finite3(
                get(d, "size")?.ok_or("shape 'box' needs 'size' = [w, h, d]")?,
                "size",
            )?;
            if size.min_element() <= 0.0 {
                return Err(format!("size {size} must be positive"));
            }
            let inward = get(d, "inward")?.unwrap_or(false);
            Ok(vec![make(
                shrad::scene::box_mesh(0.5 * size, inward),
                material,
            )])
        }
        "mesh" => {
            only(&["corners", "size", "inward"], "mesh")?;
            if let Some(file) = get::<std::path::PathBuf>(d, "file")? {
                only(&["positions", "triangles", "colors"], "mesh with a 'file'")?;
                return from_file(&file, warnings, |part| {
                    let m = Material {
                        reflectance: reflectance.unwrap_or(part.material.reflectance),
                        emitted_radiance: emission.unwrap_or(part.material.emitted_radiance),
                        double_sided: get(d, "double_sided")
                            .ok()
                            .flatten()
                            .unwrap_or(part.material.double_sided),
                        base_color_texture: part
                            .material
                            .base_color_texture
                            .clone()
                            .filter(|_| reflectance.is_none()),
                        emissive_texture: part
                            .material
                            .emissive_texture
                            .clone()
                            .filter(|_| emission.is_none()),
                    };
                    let mut mesh = part.mesh.clone();
                    if reflectance.is_some() {
                        mesh.colors.clear();
                    }
                    let mut o = make(mesh, m);
                    o.name = format!("{name}/{}", part.name);
                    o.world_from_object = rest * part.world_from_object;
                    o.node_animation = part.node_animation.clone().map(|mut n| {
                        n.outer = rest * n.outer;
                        n
                    });
                    o.role = role.or(part.role);
                    o.patch_size = patch_size.or(part.patch_size);
                    if o.animation.is_none() {
                        o.animation = part.animation.clone();
                    }
                    o
                });
            }
            let positions = d
                .get_item("positions")
                .map_err(|e| e.to_string())?
                .ok_or("shape 'mesh' needs 'positions' (N, 3) and 'triangles' (M, 3), or 'file'")?;
            let positions: PyArrayLike2<'_, f32, AllowTypeChange> = arrays::aligned(&positions)
                .map_err(|e| e.to_string())?
                .extract()
                .map_err(|e| format!("'positions' must be an (N, 3) array of numbers: {e}"))?;
            let positions =
                arrays::read_vec3s(&positions, "'positions'").map_err(|e| e.to_string())?;
            let triangles = d
                .get_item("triangles")
                .map_err(|e| e.to_string())?
                .ok_or("shape 'mesh' needs 'triangles' (M, 3)")?;
            let triangles: PyArrayLike2<'_, i64, AllowTypeChange> = arrays::aligned(&triangles)
                .map_err(|e| e.to_string())?
                .extract()
                .map_err(|e| format!("'triangles' must be an (M, 3) array of integers: {e}"))?;
            let triangles = arrays::read_triangles(&triangles, positions.len(), "'triangles'")
                .map_err(|e| e.to_string())?;
            let mut mesh = Mesh::new(positions, triangles);
            if let Some(colors) = d.get_item("colors").map_err(|e| e.to_string())? {
                let colors: PyArrayLike2<'_, f32, AllowTypeChange> = arrays::aligned(&colors)
                    .map_err(|e| e.to_string())?
                    .extract()
                    .map_err(|e| format!("'colors' must be an (N, 3) array of numbers: {e}"))?;
                let colors = arrays::read_vec3s(&colors, "'colors'").map_err(|e| e.to_string())?;
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
            Ok(vec![make(mesh, material)])
        }
        s => Err(format!("shape '{s}' is not quad, box or mesh")),
    }
}

/// The objects of a glTF / OBJ / TOML file, each made into one of this entry's.
fn from_file(
    file: &Path,
    warnings: &mut Vec<String>,
    make: impl Fn(&Object) -> Object,
) -> Result<Vec<Object>, String> {
    let sub = shrad::scene::load(file, &LoadOptions::default()).map_err(|e| e.to_string())?;
    warnings.extend(
        sub.warnings
            .iter()
            .map(|w| format!("{}: {w}", file.display())),
    );
    Ok(sub.objects.iter().map(make).collect())
}

/// `transform` (4x4) or `position` / `rotation_*` / `scale`.
fn rest_transform(d: &Bound<'_, PyDict>) -> Result<Affine3A, String> {
    if let Some(m) = d.get_item("transform").map_err(|e| e.to_string())? {
        for k in ["position", "rotation_deg", "rotation_quat", "scale"] {
            if d.contains(k).unwrap_or(false) {
                return Err(format!("give 'transform' or '{k}', not both"));
            }
        }
        let m: PyArrayLike2<'_, f64, AllowTypeChange> = arrays::aligned(&m)
            .map_err(|e| e.to_string())?
            .extract()
            .map_err(|e| format!("'transform' must be a 4x4 matrix: {e}"))?;
        return arrays::read_affine(&m, "'transform'").map_err(|e| e.to_string());
    }
    let position = finite3(get(d, "position")?.unwrap_or([0.0; 3]), "position")?;
    let rot = rotation(d)?;
    let scale = match d.get_item("scale").map_err(|e| e.to_string())? {
        None => Vec3::ONE,
        Some(s) => match (s.extract::<f32>(), s.extract::<[f32; 3]>()) {
            (Ok(u), _) => Vec3::splat(u),
            (_, Ok(a)) => Vec3::from(a),
            _ => {
                return Err(format!(
                    "'scale' must be a number or [x, y, z], got {}",
                    short_repr(&s)
                ))
            }
        },
    };
    if !(scale.is_finite() && scale.min_element() > 0.0) {
        return Err(format!("scale {scale} must be positive"));
    }
    Ok(Affine3A::from_scale_rotation_translation(
        scale, rot, position,
    ))
}

fn animation(d: &Bound<'_, PyDict>) -> Result<Option<Animation>, String> {
    let keys: Option<Bound<'_, PyList>> = get(d, "key")?;
    let emission_keys: Option<Bound<'_, PyList>> = get(d, "emission_key")?;
    let step = match get::<String>(d, "interpolation")?.as_deref() {
        None | Some("linear") => false,
        Some("step") => true,
        Some(s) => return Err(format!("interpolation '{s}' is not linear or step")),
    };
    if keys.is_none() && emission_keys.is_none() {
        if d.contains("interpolation").unwrap_or(false) {
            return Err("'interpolation' given without any 'key' or 'emission_key'".into());
        }
        return Ok(None);
    }
    let mut anim = Animation {
        keys: Vec::new(),
        emission: Vec::new(),
        step,
    };
    for (k, key) in keys.iter().flatten().enumerate() {
        let key = key
            .cast_into::<PyDict>()
            .map_err(|_| format!("key {k} must be a dict"))?;
        let at = |m: String| format!("key {k}: {m}");
        check_keys(
            &key,
            &["time", "translation", "rotation_deg", "rotation_quat"],
            &format!("key {k}"),
        )?;
        let time: f32 = get(&key, "time")
            .map_err(at)?
            .ok_or_else(|| at("needs 'time'".into()))?;
        if !time.is_finite() {
            return Err(at("time must be finite".into()));
        }
        anim.keys.push(Keyframe {
            time,
            translation: finite3(
                get(&key, "translation").map_err(at)?.unwrap_or([0.0; 3]),
                "translation",
            )
            .map_err(at)?,
            rotation: rotation(&key).map_err(at)?,
        });
    }
    for (k, key) in emission_keys.iter().flatten().enumerate() {
        let key = key
            .cast_into::<PyDict>()
            .map_err(|_| format!("emission_key {k} must be a dict"))?;
        let at = |m: String| format!("emission_key {k}: {m}");
        check_keys(&key, &["time", "emission"], &format!("emission_key {k}"))?;
        let time: f32 = get(&key, "time")
            .map_err(at)?
            .ok_or_else(|| at("needs 'time'".into()))?;
        let e = finite3(
            get(&key, "emission")
                .map_err(at)?
                .ok_or_else(|| at("needs 'emission'".into()))?,
            "emission",
        )
        .map_err(at)?;
        if !time.is_finite() || e.min_element() < 0.0 {
            return Err(at("time must be finite and emission >= 0".into()));
        }
        anim.emission.push(EmissionKey {
            time,
            emitted_radiance: e,
        });
    }
    anim.keys.sort_by(|a, b| a.time.total_cmp(&b.time));
    anim.emission.sort_by(|a, b| a.time.total_cmp(&b.time));
    Ok(Some(anim))
}
