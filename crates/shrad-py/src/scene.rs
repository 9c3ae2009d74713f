//! Scenes: `shrad.load(path_or_builtin, ...)` (every format the CLI reads) and the
//! `Scene` it returns; `Scene.objects` lists names, roles and bounds. `shrad.load_dict`
//! is in `scene_dict.rs`.

use std::sync::Arc;

use glam::Vec3;
use pyo3::prelude::*;
use shrad::scene::{Aabb, LoadOptions, Scene};
use shrad::PatchSizing;

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
    fn with_patches(&self, patches: Option<i64>, patch_size: Option<f32>) -> PyResult<PyScene> {
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

/// Patch sizing by the library's one rule: `patch_size`, else `patches`, else the scene
/// file's settings, else the default. Both given is a ValueError, as the CLI's two options
/// conflict (`patch_size` won, silently).
pub fn sizing(
    scene: &Scene,
    patches: Option<i64>,
    patch_size: Option<f32>,
) -> PyResult<PatchSizing> {
    if let (Some(n), Some(h)) = (patches, patch_size) {
        return Err(pyo3::exceptions::PyValueError::new_err(format!(
            "give patches or patch_size, not both (got patches={n}, patch_size={h})"
        )));
    }
    // Taken as a signed number, so that a negative count is a ValueError naming it (as
    // `usize`, pyo3 raised an OverflowError that named the argument only in its notes).
    let patches = (patches.map(usize::try_from).transpose()).map_err(|_| {
        pyo3::exceptions::PyValueError::new_err(format!(
            "patches must be a positive count of patches, got {}",
            patches.unwrap_or_default()
        ))
    })?;
    PatchSizing::choose(
        patch_size,
        patches,
        &scene.settings,
        ["patch_size", "patches"],
    )
    .map_err(crate::to_py_err)
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
    patches: Option<i64>,
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
