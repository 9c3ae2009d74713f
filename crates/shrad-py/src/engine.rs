//! `shrad.Engine`: the library's [`shrad::engine::Engine`] behind a mutex. Every call that
//! works (building, stepping, rendering, the reference solve of `error()`, the bake) runs
//! with the GIL released, so other Python threads go on, and two engines solve in parallel.

use std::sync::Mutex;

use glam::Vec3;
use numpy::{AllowTypeChange, PyArray1, PyArray2, PyArrayLike2, PyArrayMethods};
use pyo3::exceptions::PyValueError;
use pyo3::prelude::*;
use pyo3::types::PyDict;
use shrad::engine::Engine;
use shrad::render::{RenderOptions, Shading};

use crate::args::{self, ObjRef};
use crate::arrays;
use crate::scene::PyScene;
use crate::to_py_err;

mod locking;

/// The live engine over one scene: a patched world and one solver.
///
/// ``Engine(scene, solver="dispersive", preset="default", *, backend="auto", threads=None, **settings)``
///
/// ``solver`` is ``"dispersive"`` (the paper's method), ``"grid"`` (the uniform probe grid
/// baseline) or ``"reference"`` (converged radiosity every frame); ``preset`` one of
/// ``shrad.presets(solver)``; ``settings`` the solver's keys (``shrad.options(solver)``
/// lists them with their ranges and defaults), e.g. ``cube_res=64, schedule="full"``.
/// ``backend`` is ``"auto"``, ``"embree"`` or ``"bvh"``. ``threads`` gives the engine
/// worker threads of its own (default: the process's shared pool, one per core), so that
/// engines in several Python threads each keep their cores. The precomputation runs here,
/// with the GIL released; Ctrl-C (KeyboardInterrupt) stops it (no engine is made).
///
/// Steer it with ``set_transform``, ``set_emission``, ``set_light``, ``set_sky``, ``set_time``, ``set_option``;
/// advance it with ``step()``; read ``radiosity``, ``vertex_colors``, the patch arrays
/// (``centres``, ``normals``, ``areas``, ``object_ids``), ``render(...)`` a picture,
/// measure ``error()`` against a reference solve, ``export_gltf(path)`` the baked light.
#[pyclass(name = "Engine", module = "shrad", frozen)]
pub struct PyEngine {
    inner: Mutex<Engine>,
    /// The engine's own worker threads (`threads=`), else rayon's global pool.
    pool: Option<rayon::ThreadPool>,
}

#[pymethods]
impl PyEngine {
    #[new]
    #[pyo3(signature = (scene, solver="dispersive", preset="default", *, backend="auto", threads=None, **settings))]
    fn new(
        py: Python<'_>,
        scene: &PyScene,
        solver: &str,
        preset: &str,
        backend: &str,
        threads: Option<i64>,
        settings: Option<&Bound<'_, PyDict>>,
    ) -> PyResult<PyEngine> {
        let pool = match threads {
            None => None,
            Some(n) if (1..=1024).contains(&n) => Some(
                rayon::ThreadPoolBuilder::new()
                    .num_threads(n as usize)
                    .build()
                    .map_err(|e| pyo3::exceptions::PyOSError::new_err(format!("threads: {e}")))?,
            ),
            Some(n) => {
                return Err(PyValueError::new_err(format!(
                    "threads must be between 1 and 1024, got {n}"
                )))
            }
        };
        let choice = crate::settings::choice(solver, preset, settings)?;
        let backend = args::backend(backend)?;
        let (scene, sizing) = (scene.scene.as_ref().clone(), scene.sizing);
        let engine = crate::stop::interruptible(py, |stop| {
            let build = || Engine::new_with_progress(scene, sizing, backend, choice, stop);
            match &pool {
                Some(p) => p.install(build),
                None => build(),
            }
        })?;
        Ok(PyEngine {
            inner: Mutex::new(engine),
            pool,
        })
    }

    /// The solver in use: ``"dispersive"``, ``"grid"`` or ``"reference"``.
    #[getter]
    fn solver(&self, py: Python<'_>) -> &'static str {
        self.with(py, |e| e.solver_choice().name())
    }

    /// Every setting of the solver in use, a list of ``(key, value as text)`` pairs.
    #[getter]
    fn settings(&self, py: Python<'_>) -> PyResult<Vec<(String, String)>> {
        self.with(py, |e| {
            let c = e.solver_choice();
            c.keys()
                .iter()
                .map(|k| Ok((k.name.to_string(), c.get(k.name)?)))
                .collect::<Result<Vec<_>, shrad::Error>>()
        })
        .map_err(to_py_err)
    }

    /// Change one setting by name (``set_option("cube_res", 64)``). Returns the
    /// milliseconds the precomputation took when the key needs it again, else None (a
    /// schedule key applies from the next frame). A bad key or value raises ValueError and
    /// changes nothing.
    fn set_option(
        &self,
        py: Python<'_>,
        key: &str,
        value: &Bound<'_, PyAny>,
    ) -> PyResult<Option<f64>> {
        let value = crate::settings::value_text(key, value)?;
        self.with(py, |e| e.set_option(key, &value))
            .map(|r| r.map(|r| r.precompute_ms))
            .map_err(to_py_err)
    }

    /// The value of setting ``key`` of the solver in use, as text.
    fn option(&self, py: Python<'_>, key: &str) -> PyResult<String> {
        self.with(py, |e| e.option(key)).map_err(to_py_err)
    }

    /// Switch the solver (``set_solver("grid", "paper4", cube_res=16)``): its
    /// precomputation runs again and the state restarts from the lights' emission. Returns
    /// the milliseconds that took.
    #[pyo3(signature = (solver, preset="default", **settings))]
    fn set_solver(
        &self,
        py: Python<'_>,
        solver: &str,
        preset: &str,
        settings: Option<&Bound<'_, PyDict>>,
    ) -> PyResult<f64> {
        let choice = crate::settings::choice(solver, preset, settings)?;
        self.with(py, |e| e.set_solver(choice))
            .map(|r| r.precompute_ms)
            .map_err(to_py_err)
    }

    /// Put object ``obj`` (a name or an index) at ``matrix``, a 4x4 world-from-object
    /// matrix (any affine map; column vectors, ``p' = M @ [x, y, z, 1]``). The scheduler
    /// updates it and its neighbours first.
    fn set_transform(
        &self,
        py: Python<'_>,
        obj: ObjRef,
        matrix: &Bound<'_, PyAny>,
    ) -> PyResult<()> {
        let o = self.object(py, &obj)?;
        let matrix: PyArrayLike2<'_, f64, AllowTypeChange> =
            arrays::aligned(matrix)?.extract().map_err(|e| {
                PyValueError::new_err(format!("matrix must be a 4x4 array of numbers: {e}"))
            })?;
        let m = arrays::read_affine(&matrix, "matrix")?;
        self.with(py, |e| e.set_transform(o, m)).map_err(to_py_err)
    }

    /// Object ``obj``'s current world-from-object matrix (4x4 float64).
    fn transform<'py>(&self, py: Python<'py>, obj: ObjRef) -> PyResult<Bound<'py, PyArray2<f64>>> {
        let o = self.object(py, &obj)?;
        let m = self.with(py, |e| e.transform(o));
        arrays::affine(py, m)
    }

    /// Set object ``obj``'s emitted radiance (linear RGB, W/(m^2 sr); zero switches it off).
    fn set_emission(&self, py: Python<'_>, obj: ObjRef, rgb: [f32; 3]) -> PyResult<()> {
        let o = self.object(py, &obj)?;
        self.with(py, |e| e.set_emission(o, Vec3::from(rgb)))
            .map_err(to_py_err)
    }

    /// Set object ``obj``'s reflectance factor (linear RGB, each in [0, 1]; its base-colour
    /// texture and vertex colours multiply it): a surface painted another colour.
    fn set_reflectance(&self, py: Python<'_>, obj: ObjRef, rgb: [f32; 3]) -> PyResult<()> {
        let o = self.object(py, &obj)?;
        self.with(py, |e| e.set_reflectance(o, Vec3::from(rgb)))
            .map_err(to_py_err)
    }

    /// Set the sky: ``radiance`` a uniform linear RGB radiance, or ``file`` an equirectangular
    /// map (linear ``.exr`` or ``.hdr``, top row +Y) turned ``rotate_deg`` about +Y and scaled
    /// by ``scale``; neither removes the sky. A light change: every object wakes.
    #[pyo3(signature = (radiance=None, file=None, rotate_deg=0.0, scale=1.0))]
    fn set_sky(
        &self,
        py: Python<'_>,
        radiance: Option<[f32; 3]>,
        file: Option<std::path::PathBuf>,
        rotate_deg: f32,
        scale: f32,
    ) -> PyResult<()> {
        let env = crate::scene_dict::environment(radiance, file, rotate_deg, scale)?;
        self.with(py, move |e| e.set_sky(env)).map_err(to_py_err)
    }

    /// Move punctual light ``light`` (a name or an index) and set its colour and intensity:
    /// ``matrix`` a 4x4 world-from-light matrix (it shines along that frame's -Z; ``None``
    /// keeps its place), ``rgb`` linear colour and ``intensity`` photometric, candela (point,
    /// spot) or lux (directional), 683 lm/W (``None`` keeps each as it is).
    #[pyo3(signature = (light, matrix=None, rgb=None, intensity=None))]
    fn set_light(
        &self,
        py: Python<'_>,
        light: ObjRef,
        matrix: Option<&Bound<'_, PyAny>>,
        rgb: Option<[f32; 3]>,
        intensity: Option<f32>,
    ) -> PyResult<()> {
        let l = match &light {
            ObjRef::Index(i) => {
                let n = self.with(py, |e| e.world().scene.lights.len());
                ObjRef::index_within(*i, n, "light")?
            }
            ObjRef::Name(name) => self.with(py, |e| e.light(name)).map_err(to_py_err)?,
        };
        let m = match matrix {
            Some(matrix) => {
                let matrix: PyArrayLike2<'_, f64, AllowTypeChange> =
                    arrays::aligned(matrix)?.extract().map_err(|e| {
                        PyValueError::new_err(format!("matrix must be a 4x4 array of numbers: {e}"))
                    })?;
                Some(arrays::read_affine(&matrix, "matrix")?)
            }
            None => None,
        };
        self.with(py, |e| {
            let Some(now) = e.world().scene.lights.get(l).map(|n| n.at(e.time())) else {
                return Err(shrad::Error::Invalid(format!(
                    "light index {l} out of range ({} lights)",
                    e.world().scene.lights.len()
                )));
            };
            let (m, c, i) = (
                m.unwrap_or(now.world_from_light),
                rgb.map_or(now.color, Vec3::from),
                intensity.unwrap_or(now.intensity),
            );
            e.set_light(l, m, c, i)
        })
        .map_err(to_py_err)
    }

    /// Go to time ``t`` (seconds) on the scene's animation.
    fn set_time(&self, py: Python<'_>, t: f32) -> PyResult<()> {
        self.with(py, |e| e.set_time(t)).map_err(to_py_err)
    }

    /// The time the world is at (seconds).
    #[getter]
    fn time(&self, py: Python<'_>) -> f32 {
        self.with(py, |e| e.world().time)
    }

    /// One frame (GIL released). With ``budget_ms`` the dispersive solver updates as many
    /// objects as fit in it (at least one). Returns the frame's statistics as a dict
    /// (``frame_ms``, ``objects_updated``, ``stalest``, ``energy``, ``diverged``, ...).
    #[pyo3(signature = (budget_ms=None))]
    fn step<'py>(&self, py: Python<'py>, budget_ms: Option<f32>) -> PyResult<Bound<'py, PyAny>> {
        let stats = match budget_ms {
            None => self.with(py, |e| Ok(e.step())),
            // Checked here for every solver (the library checks the dispersive's only).
            Some(ms) if !(ms.is_finite() && ms > 0.0) => Err(shrad::Error::Invalid(format!(
                "budget_ms must be a positive number, got {ms}"
            ))),
            Some(ms) => self.with(py, |e| e.step_within(ms)),
        }
        .map_err(to_py_err)?;
        crate::to_py(py, &stats)
    }

    /// Frames a static scene needs to converge: every object updated ``passes`` times
    /// (0 to 1000).
    #[pyo3(signature = (passes=2))]
    fn frames_to_converge(&self, py: Python<'_>, passes: i64) -> PyResult<usize> {
        let passes = args::passes(passes)?;
        Ok(self.with(py, |e| e.frames_to_converge(passes)))
    }

    /// Step until a static scene has converged (every object updated ``passes`` times, 0 to
    /// 1000, then, for the dispersive solver and the grid, until a frame changes the radiosity by less
    /// than 1e-4); the statistics of every frame. Ctrl-C (KeyboardInterrupt) stops it
    /// between two frames, the engine whole.
    #[pyo3(signature = (passes=2))]
    fn converge<'py>(&self, py: Python<'py>, passes: i64) -> PyResult<Bound<'py, PyAny>> {
        let passes = args::passes(passes)?;
        let stats = self.converge_interruptible(py, passes)?;
        crate::to_py(py, &stats)
    }

    /// Frames stepped since the engine (or its solver) was made.
    #[getter]
    fn frames(&self, py: Python<'_>) -> u64 {
        self.with(py, |e| e.frames())
    }

    /// Number of patches.
    fn __len__(&self, py: Python<'_>) -> usize {
        self.with(py, |e| e.world().patches.len())
    }

    /// Radiosity ``B`` of every patch: (N, 3) float32, linear RGB, W/m^2 (a copy: the
    /// engine's state moves on with the next step).
    #[getter]
    fn radiosity<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyArray2<f32>>> {
        let b = self.with(py, |e| e.radiosity().to_vec());
        arrays::vec3s(py, b)
    }

    /// Radiosity at every shading vertex (area-weighted over the patches that share it):
    /// (V, 3) float32, the colours a viewer draws.
    #[getter]
    fn vertex_colors<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyArray2<f32>>> {
        let v = self.with(py, |e| e.vertex_colors());
        arrays::vec3s(py, v)
    }

    /// World-space centre of every patch: (N, 3) float32.
    #[getter]
    fn centres<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyArray2<f32>>> {
        let v = self.with(py, |e| e.world().patches.centre.clone());
        arrays::vec3s(py, v)
    }

    /// The dispersive solver's corner probes as they stand now (8 per interior object,
    /// captured from the current radiosity), for lighting dynamic objects elsewhere: a dict
    /// with ``positions`` (P, 3), ``sh`` (P, 9, 3: radiance SH in three.js's
    /// ``LightProbe`` order and convention), ``irradiance_sh`` (P, 9, 3: the same times the
    /// clamped-cosine factors, ``E(n) = sum_k c_k Y_k(n)``), ``objects`` and ``corners``
    /// (P,) and ``states`` (``valid``, ``repaired``, ``invalid``), and ``bands`` (3).
    /// A ValueError for solvers without per-object probes.
    fn probes<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyDict>> {
        let (probes, solver) = self.with(py, |e| {
            let name = e.solver_choice().name().to_string();
            (shrad::probe_export::corner_probes(e), name)
        });
        let probes = probes.ok_or_else(|| {
            PyValueError::new_err(format!(
                "probes: the {solver} solver has no per-object probes (use the dispersive solver)"
            ))
        })?;
        let n = probes.len();
        let coefficients = |f: &dyn Fn(&shrad::probe_export::ExportedProbe) -> [Vec3; 9]| {
            let flat: Vec<f32> = probes
                .iter()
                .flat_map(f)
                .flat_map(|c| c.to_array())
                .collect();
            PyArray1::from_vec(py, flat).reshape([n, 9, 3])
        };
        let d = PyDict::new(py);
        d.set_item(
            "positions",
            arrays::vec3s(py, probes.iter().map(|p| p.position).collect())?,
        )?;
        d.set_item("sh", coefficients(&|p| p.sh)?)?;
        d.set_item("irradiance_sh", coefficients(&|p| p.irradiance_sh())?)?;
        let objects: Vec<i64> = probes.iter().map(|p| p.object as i64).collect();
        let corners: Vec<i64> = probes.iter().map(|p| p.corner as i64).collect();
        d.set_item("objects", PyArray1::from_vec(py, objects))?;
        d.set_item("corners", PyArray1::from_vec(py, corners))?;
        let states: Vec<String> = probes
            .iter()
            .map(|p| format!("{:?}", p.state).to_lowercase())
            .collect();
        d.set_item("states", states)?;
        d.set_item("bands", shrad::probe_export::BANDS)?;
        Ok(d)
    }

    /// Write ``probes()`` as JSON at ``path``: the file ``shrad bake --probes corners``
    /// writes beside its glTF (``format: "shrad-probes"``; docs/python.md). Returns
    /// ``{"path", "probes"}``. A ValueError for solvers without per-object probes; an
    /// OSError naming the file when it cannot be written (nothing is left behind).
    fn export_probes<'py>(
        &self,
        py: Python<'py>,
        path: std::path::PathBuf,
    ) -> PyResult<Bound<'py, PyDict>> {
        use shrad::probe_export::{corner_probes, to_json_text};
        // The scene file is checked first: the probes' JSON is not made to be refused.
        let (json, solver) = self
            .with(py, |e| {
                shrad::bake::refuse_overwriting_scene(e, &path).map(|()| {
                    let json = corner_probes(e).map(|p| (to_json_text(e, &p), p.len()));
                    (json, e.solver_choice().name())
                })
            })
            .map_err(to_py_err)?;
        let (text, n) = json.ok_or_else(|| {
            PyValueError::new_err(format!(
                "export_probes: the {solver} solver has no per-object probes (use the dispersive solver)"
            ))
        })?;
        py.detach(|| {
            shrad::scene::write_atomic(&path, |tmp| {
                std::fs::write(tmp, &text).map_err(|e| e.to_string())
            })
        })
        .map_err(|e| to_py_err(shrad::scene::SceneError::Write(e).into()))?;
        let d = PyDict::new(py);
        // A str, as export_gltf's and bake's `path` (it was a PosixPath).
        d.set_item("path", path.to_string_lossy())?;
        d.set_item("probes", n)?;
        Ok(d)
    }

    /// World-space unit normal of every patch: (N, 3) float32.
    #[getter]
    fn normals<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyArray2<f32>>> {
        let v = self.with(py, |e| e.world().patches.normal.clone());
        arrays::vec3s(py, v)
    }

    /// World area of every patch: (N,) float32.
    #[getter]
    fn areas<'py>(&self, py: Python<'py>) -> Bound<'py, PyArray1<f32>> {
        let v = self.with(py, |e| e.world().patches.area.clone());
        PyArray1::from_vec(py, v)
    }

    /// The object (its index in ``Scene.objects``) of every patch: (N,) uint32.
    #[getter]
    fn object_ids<'py>(&self, py: Python<'py>) -> Bound<'py, PyArray1<u32>> {
        let v = self.with(py, |e| e.world().patches.object.clone());
        PyArray1::from_vec(py, v)
    }

    /// Reflectance of every patch (the area average of its material): (N, 3) float32.
    #[getter]
    fn reflectance<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyArray2<f32>>> {
        let v = self.with(py, |e| e.world().reflectance.clone());
        arrays::vec3s(py, v)
    }

    /// The objects, as ``Scene.objects`` lists them (names, roles, bounds at rest).
    #[getter]
    fn objects(&self, py: Python<'_>) -> Vec<crate::scene::PyObjectInfo> {
        let scene = self.with(py, |e| e.world().scene.clone());
        PyScene {
            scene: std::sync::Arc::new(scene),
            sizing: shrad::PatchSizing::Count(1),
        }
        .object_list()
    }

    /// A linear picture: (height, width, 3) float32 radiance (``B / pi`` on surfaces,
    /// ``L_e`` on lights, 0 for the background). ``camera`` is a dict ``{"eye": [..],
    /// "target": [..], "yfov_deg": 40}``, or None for the scene's camera (or one that frames
    /// it); ``shading`` is ``"smooth"`` (interpolated) or ``"flat"`` (one colour per patch).
    #[pyo3(signature = (width=512, height=512, *, spp=4, camera=None, shading="smooth"))]
    fn render<'py>(
        &self,
        py: Python<'py>,
        width: i64,
        height: i64,
        spp: i64,
        camera: Option<&Bound<'py, PyDict>>,
        shading: &str,
    ) -> PyResult<Bound<'py, PyAny>> {
        let (width, height, spp) = args::image_size(width, height, spp)?;
        let camera = camera.map(args::camera_from).transpose()?;
        let shading = match shading {
            "smooth" => Shading::Smooth,
            "flat" => Shading::Flat,
            s => {
                return Err(PyValueError::new_err(format!(
                    "shading '{s}' is not smooth or flat"
                )))
            }
        };
        let options = RenderOptions {
            width,
            height,
            spp,
            shading,
        };
        let image = self
            .with(py, |e| e.render(camera.as_ref(), &options))
            .map_err(to_py_err)?;
        arrays::image(py, image.pixels, width as usize, height as usize)
    }

    /// The relative L2 error of the current state against a reference solve of the same
    /// state (area-weighted, lights left out; fractions, not percent): a dict with
    /// ``overall``, ``boundary`` and ``interior`` (NaN where a role has no patches).
    /// ``reference``: the reference's preset, ``"fast"`` (the default: 64 form-factor rays
    /// a patch, 16 shadow rays) or ``"standard"`` (256 and 64, as ``shrad render
    /// --compare``). Ctrl-C (KeyboardInterrupt) stops the reference solve.
    #[pyo3(signature = (*, reference=None))]
    fn error<'py>(
        &self,
        py: Python<'py>,
        reference: Option<String>,
    ) -> PyResult<Bound<'py, PyAny>> {
        let options = match reference.as_deref() {
            None => None,
            Some(name) => match shrad::solver::SolverChoice::preset("reference", name) {
                Ok(shrad::solver::SolverChoice::Reference(r)) => Some(r),
                _ => {
                    return Err(PyValueError::new_err(format!(
                    "error: reference '{name}' is not a preset of the reference (fast, standard)"
                )))
                }
            },
        };
        let e = self.with_stoppable(py, |e, stop| match &options {
            Some(o) => e.error_against(o, stop),
            None => e.error_with_progress(stop),
        })?;
        // Built here, not through JSON: JSON has no NaN, and a role without patches was None.
        let dict = PyDict::new(py);
        dict.set_item("overall", e.overall)?;
        dict.set_item("boundary", e.boundary)?;
        dict.set_item("interior", e.interior)?;
        Ok(dict.into_any())
    }

    /// Write the current light (no stepping) as glTF: ``.glb``, or ``.gltf`` with a ``.bin``
    /// beside it. Each object is a mesh in world space whose ``COLOR_0`` is
    /// ``clamp(exposure * B / pi, 0, 1)`` under an unlit material (``KHR_materials_unlit``),
    /// so three.js, Blender or Godot show the light as it is; ``_RADIOSITY`` holds the
    /// unclamped radiosity ``B``. ``exposure`` None: as a PNG's automatic exposure. Returns
    /// what was written (``path``, ``exposure``, ``meshes``, ``vertices``, ``triangles``).
    #[pyo3(signature = (path, *, exposure=None))]
    fn export_gltf<'py>(
        &self,
        py: Python<'py>,
        path: std::path::PathBuf,
        exposure: Option<f32>,
    ) -> PyResult<Bound<'py, PyAny>> {
        let baked = self
            .with(py, |e| shrad::bake::write_gltf(e, &path, exposure))
            .map_err(to_py_err)?;
        crate::to_py(py, &baked)
    }

    /// What ``shrad bake`` does: go to ``time``, step until every object has been updated
    /// ``passes`` times, and write ``path`` as ``export_gltf`` does; with ``frames``, a
    /// sequence of that many files evenly over the animation (``out.glb`` ->
    /// ``out_0000.glb``, ``out_0001.glb``, ...), each a whole scene at its pose, at the first
    /// file's exposure. Returns one dict per file. Ctrl-C (KeyboardInterrupt) stops it
    /// before any file is in place, the engine whole at the frame it reached.
    /// ``lightmap=True`` writes the light into a lightmap as ``shrad bake --lightmap`` does:
    /// a texture atlas over ``TEXCOORD_1`` inside the glTF, and beside it ``OUT.lightmap.exr``
    /// (linear, ``E / pi``) or with ``lightmap_format="rgbm"`` an RGBM ``OUT.lightmap.png``;
    /// its texel edge ``texel_size`` (scene units) or the atlas's side ``lightmap_res``
    /// (texels, 8 to 16384; 1024 when neither is given). Each dict then names its
    /// ``lightmap_file`` (a path) and ``lightmap_encoding``.
    #[pyo3(signature = (
        path, *, time=None, frames=None, passes=2, exposure=None,
        lightmap=false, texel_size=None, lightmap_res=None, lightmap_format=None
    ))]
    #[allow(clippy::too_many_arguments)] // Python's keyword arguments, as the CLI's flags
    fn bake<'py>(
        &self,
        py: Python<'py>,
        path: std::path::PathBuf,
        time: Option<f32>,
        frames: Option<i64>,
        passes: i64,
        exposure: Option<f32>,
        lightmap: bool,
        texel_size: Option<f32>,
        lightmap_res: Option<i64>,
        lightmap_format: Option<String>,
    ) -> PyResult<Bound<'py, PyAny>> {
        let passes = args::passes(passes)?;
        let options = shrad::bake::BakeOptions {
            time,
            frames: frames.map(args::frames).transpose()?,
            passes,
            exposure,
        };
        let layout = (texel_size, lightmap_res, lightmap_format.as_deref());
        let lightmap = args::lightmap(lightmap, layout)?;
        let baked = self.with_stoppable(py, |e, stop| match &lightmap {
            Some(l) => shrad::lightmap::bake_with_progress(e, &path, &options, l, stop),
            None => shrad::bake::bake_with_progress(e, &path, &options, stop),
        })?;
        crate::to_py(py, &baked)
    }

    fn __repr__(&self, py: Python<'_>) -> String {
        self.with(py, |e| {
            format!(
                "Engine({:?}, solver={:?}, {} patches, {} frames)",
                e.world().scene.source,
                e.solver_choice().name(),
                e.world().patches.len(),
                e.frames()
            )
        })
    }
}
