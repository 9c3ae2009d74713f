//! Arguments of `shrad.Engine`'s methods read from Python with errors that say what is
//! wrong in the caller's terms: an object by name or index, a camera dict, a backend, a
//! number of passes, a picture's size.

use glam::Vec3;
use pyo3::exceptions::{PyTypeError, PyValueError};
use pyo3::prelude::*;
use pyo3::types::{PyBool, PyDict, PyString};
use shrad::scene::Camera;

/// An object (or a punctual light) by name or by index.
pub enum ObjRef {
    /// Its index in `Scene.objects`, as given (checked against the scene where it is used:
    /// a negative or too large index is out of range).
    Index(i128),
    /// Its name.
    Name(String),
}

impl<'a, 'py> FromPyObject<'a, 'py> for ObjRef {
    type Error = PyErr;

    /// A `str` is a name; anything with `__index__` (int, numpy integers) an index; the rest
    /// (a float, None, a bool) a TypeError saying what was expected.
    fn extract(obj: Borrowed<'a, 'py, PyAny>) -> PyResult<Self> {
        if let Ok(s) = obj.cast::<PyString>() {
            return Ok(ObjRef::Name(s.to_string()));
        }
        if !obj.is_instance_of::<PyBool>() {
            if let Ok(i) = obj.extract::<i128>() {
                return Ok(ObjRef::Index(i));
            }
        }
        Err(PyTypeError::new_err(format!(
            "an object is a name (str) or an index (int), got {} {}",
            obj.get_type().name()?,
            obj.repr()?
        )))
    }
}

impl ObjRef {
    /// The index, when it is one of `count` `what`s ("object", "light").
    pub fn index_within(i: i128, count: usize, what: &str) -> PyResult<usize> {
        usize::try_from(i)
            .ok()
            .filter(|&i| i < count)
            .ok_or_else(|| {
                PyValueError::new_err(format!("{what} index {i} out of range ({count} {what}s)"))
            })
    }
}

/// A camera from `{"eye": [..], "target": [..], "yfov_deg": 40, "aspect_ratio": 1.5}`.
pub fn camera_from(d: &Bound<'_, PyDict>) -> PyResult<Camera> {
    let get3 = |k: &str| -> PyResult<Option<Vec3>> {
        match d.get_item(k)? {
            None => Ok(None),
            Some(v) => {
                let a: [f32; 3] = v.extract().map_err(|_| {
                    PyValueError::new_err(format!("camera '{k}' must be [x, y, z]"))
                })?;
                Ok(Some(Vec3::from(a)))
            }
        }
    };
    let number = |k: &str| -> PyResult<Option<f32>> {
        d.get_item(k)?
            .map(|v| {
                v.extract::<f32>().map_err(|_| {
                    PyValueError::new_err(format!("camera '{k}' must be a number, got {v:?}"))
                })
            })
            .transpose()
    };
    for k in d.keys() {
        let k: String = k.extract()?;
        if !["eye", "target", "yfov_deg", "aspect_ratio"].contains(&k.as_str()) {
            return Err(PyValueError::new_err(format!(
                "camera: unknown key '{k}' (known: eye, target, yfov_deg, aspect_ratio)"
            )));
        }
    }
    let eye = get3("eye")?.ok_or_else(|| PyValueError::new_err("camera needs 'eye'"))?;
    let target = get3("target")?.ok_or_else(|| PyValueError::new_err("camera needs 'target'"))?;
    let yfov = number("yfov_deg")?.unwrap_or(40.0);
    if !(eye.is_finite() && target.is_finite()) || (eye - target).length() < 1e-9 {
        return Err(PyValueError::new_err(
            "camera: eye and target must be finite and apart",
        ));
    }
    if !(yfov > 0.0 && yfov < 180.0) {
        return Err(PyValueError::new_err(format!(
            "camera: yfov_deg {yfov} must be between 0 and 180"
        )));
    }
    let aspect_ratio = number("aspect_ratio")?;
    if let Some(a) = aspect_ratio.filter(|a| !(a.is_finite() && *a > 0.0)) {
        // As a scene file's camera: the picture's shape is the render's width and height.
        return Err(PyValueError::new_err(format!(
            "camera: aspect_ratio {a} must be a positive number"
        )));
    }
    let mut c = Camera::look_at(eye, target, yfov.to_radians());
    c.aspect_ratio = aspect_ratio;
    Ok(c)
}

/// The visibility backend by name.
pub fn backend(name: &str) -> PyResult<shrad::vis::Backend> {
    use shrad::vis::Backend;
    Ok(match name {
        "auto" => Backend::Auto,
        "embree" => Backend::Embree,
        "bvh" => Backend::Bvh,
        _ => {
            return Err(PyValueError::new_err(format!(
                "backend '{name}' is not auto, embree or bvh"
            )))
        }
    })
}

/// Most `passes` that `converge`, `frames_to_converge` and `bake` take: every object
/// updated that many times is far past convergence (the default is 2), and the frames'
/// count, and the statistics kept of each, stay within reach.
pub const MAX_PASSES: usize = 1000;

/// `passes` when it is in `0..=MAX_PASSES`.
pub fn passes(passes: i64) -> PyResult<usize> {
    usize::try_from(passes)
        .ok()
        .filter(|&p| p <= MAX_PASSES)
        .ok_or_else(|| {
            PyValueError::new_err(format!(
                "passes must be between 0 and {MAX_PASSES}, got {passes}"
            ))
        })
}

/// `frames` of a sequence when it is in `1..=MAX_FRAMES` (a negative count was pyo3's
/// "can't convert negative int to unsigned", naming nothing).
pub fn frames(frames: i64) -> PyResult<usize> {
    let max = shrad::limits::MAX_FRAMES;
    usize::try_from(frames)
        .ok()
        .filter(|n| (1..=max).contains(n))
        .ok_or_else(|| {
            PyValueError::new_err(format!("frames must be between 1 and {max}, got {frames}"))
        })
}

/// A picture's `width`, `height` and `spp` as the library takes them: a negative one is
/// the library's size error with the numbers as given, as is a side beyond its limit.
pub fn image_size(width: i64, height: i64, spp: i64) -> PyResult<(u32, u32, u32)> {
    if width < 1 || height < 1 || spp < 1 {
        return Err(PyValueError::new_err(format!(
            "image size {width}x{height} with {spp} samples per pixel: each must be at least 1"
        )));
    }
    let max = shrad::limits::MAX_IMAGE_SIDE;
    if width.max(height) > max as i64 {
        return Err(PyValueError::new_err(format!(
            "image size {width}x{height}: a side may be at most {max} pixels"
        )));
    }
    // More samples than a u32 are more than any memory: the library says how much.
    Ok((
        width as u32,
        height as u32,
        u32::try_from(spp).unwrap_or(u32::MAX),
    ))
}

/// `Engine.bake`'s lightmap arguments as the library's options (`None`: no lightmap); the
/// layout's arguments without `lightmap=True` are a mistake, not silently ignored.
pub fn lightmap(
    wanted: bool,
    (texel_size, resolution, format): (Option<f32>, Option<i64>, Option<&str>),
) -> PyResult<Option<shrad::lightmap::LightmapOptions>> {
    use shrad::lightmap::{LightmapFormat, LightmapOptions};
    if !wanted {
        let given = [
            ("texel_size", texel_size.is_some()),
            ("lightmap_res", resolution.is_some()),
            ("lightmap_format", format.is_some()),
        ];
        return match given.iter().find(|(_, g)| *g) {
            Some((name, _)) => Err(PyValueError::new_err(format!(
                "{name} applies to a lightmap: add lightmap=True"
            ))),
            None => Ok(None),
        };
    }
    if texel_size.is_some() && resolution.is_some() {
        return Err(PyValueError::new_err(
            "give texel_size or lightmap_res, not both (one sets the other)",
        ));
    }
    let max = shrad::limits::MAX_IMAGE_SIDE;
    let resolution = match resolution {
        Some(n) => Some(
            u32::try_from(n)
                .ok()
                .filter(|n| (8..=max).contains(n))
                .ok_or_else(|| {
                    PyValueError::new_err(format!(
                        "lightmap_res {n}: the atlas's side must be 8 to {max} texels"
                    ))
                })?,
        ),
        None => None,
    };
    let options = LightmapOptions {
        texel_size,
        resolution,
        format: LightmapFormat::from_name(format.unwrap_or("exr")).map_err(crate::to_py_err)?,
        ..LightmapOptions::default()
    };
    if let Some(why) = options.problem() {
        return Err(PyValueError::new_err(format!("texel_size: {why}")));
    }
    Ok(Some(options))
}
