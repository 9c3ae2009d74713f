//! `shrad.write_exr`, `shrad.write_png`, `shrad.read_exr`: the CLI's image writers over
//! numpy pictures (H, W, 3), written atomically (nothing is left behind on failure).

use std::path::PathBuf;

use glam::Vec3;
use numpy::ndarray::Axis;
use numpy::{AllowTypeChange, PyArrayLike3, PyUntypedArrayMethods};
use pyo3::exceptions::PyValueError;
use pyo3::prelude::*;
use shrad::image_io::Tonemap;
use shrad::render::Image;

/// An (H, W, 3) array (any float dtype) as a library image.
fn image_from(a: &Bound<'_, PyAny>) -> PyResult<Image> {
    let a: PyArrayLike3<'_, f32, AllowTypeChange> = crate::arrays::aligned(a)?
        .extract()
        .map_err(|e| PyValueError::new_err(format!("image must be an (H, W, 3) array: {e}")))?;
    let shape = a.shape();
    if shape[2] != 3 || shape[0] == 0 || shape[1] == 0 {
        return Err(PyValueError::new_err(format!(
            "image must have shape (H, W, 3) with H, W >= 1, got {shape:?}"
        )));
    }
    check_size(shape[1], shape[0])?;
    let view = a.as_array();
    let pixels: Vec<Vec3> = match view.as_slice() {
        Some(s) => bytemuck::cast_slice::<f32, Vec3>(s).to_vec(),
        None => view
            .lanes(Axis(2))
            .into_iter()
            .map(|p| Vec3::new(p[0], p[1], p[2]))
            .collect(),
    };
    Ok(Image {
        width: shape[1] as u32,
        height: shape[0] as u32,
        emitter: vec![false; pixels.len()],
        pixels,
    })
}

/// Refuse a picture larger than any the library renders, or than memory holds, before it
/// is copied: a (100000, 100000, 3) array (a broadcast view costs numpy nothing) would abort
/// the process in the allocator. The copy and the encoder's buffers: 3 floats a pixel twice,
/// and a margin.
fn check_size(width: usize, height: usize) -> PyResult<()> {
    use shrad::limits::{available_bytes, MAX_IMAGE_SIDE};
    if width.max(height) > MAX_IMAGE_SIDE as usize {
        return Err(PyValueError::new_err(format!(
            "image of {width}x{height} pixels: a side may be at most {MAX_IMAGE_SIDE}"
        )));
    }
    let need = (width * height) as u64 * 36;
    let available = available_bytes();
    if need > available {
        return Err(PyValueError::new_err(format!(
            "image of {width}x{height} pixels would need about {:.1} GiB of memory to write \
             ({:.1} GiB available)",
            need as f64 / (1u64 << 30) as f64,
            available as f64 / (1u64 << 30) as f64
        )));
    }
    Ok(())
}

/// Write a linear OpenEXR (RGB, 32-bit float) of an (H, W, 3) picture such as
/// ``Engine.render`` returns. Raises OSError naming the file when it cannot be written.
#[pyfunction]
pub fn write_exr(py: Python<'_>, path: PathBuf, image: &Bound<'_, PyAny>) -> PyResult<()> {
    let image = image_from(image)?;
    py.detach(|| shrad::image_io::write_exr(&image, &path))
        .map_err(crate::to_py_err)
}

/// Write an 8-bit sRGB PNG of a linear (H, W, 3) picture. ``exposure`` scales the radiance
/// before encoding (None: the 99th percentile of luminance maps to 0.9, as the CLI does);
/// ``tonemap="minmax"`` is the paper's linear map from the picture's [min, max] instead.
#[pyfunction]
#[pyo3(signature = (path, image, *, exposure=None, tonemap="exposure"))]
pub fn write_png(
    py: Python<'_>,
    path: PathBuf,
    image: &Bound<'_, PyAny>,
    exposure: Option<f32>,
    tonemap: &str,
) -> PyResult<()> {
    let tonemap = match tonemap {
        "exposure" => {
            if exposure.is_some_and(|e| !(e.is_finite() && e > 0.0)) {
                return Err(PyValueError::new_err(format!(
                    "exposure must be a positive number, got {}",
                    exposure.unwrap_or_default()
                )));
            }
            Tonemap::Exposure(exposure)
        }
        "minmax" => Tonemap::MinMax,
        t => {
            return Err(PyValueError::new_err(format!(
                "tonemap '{t}' is not exposure or minmax"
            )))
        }
    };
    let image = image_from(image)?;
    py.detach(|| shrad::image_io::write_png(&image, &path, tonemap))
        .map_err(crate::to_py_err)
}

/// Read an RGB OpenEXR as an (H, W, 3) float32 array. Raises OSError naming the file.
#[pyfunction]
pub fn read_exr<'py>(py: Python<'py>, path: PathBuf) -> PyResult<Bound<'py, PyAny>> {
    let image = py
        .detach(|| shrad::image_io::read_exr(&path))
        .map_err(crate::to_py_err)?;
    crate::arrays::image(
        py,
        image.pixels,
        image.width as usize,
        image.height as usize,
    )
}
