//! numpy in and out. Out: a `Vec` the library made is handed to numpy as the array's own
//! memory (`PyArray::from_vec`, then a reshape, which is a view): no copy. In: arrays of
//! the right dtype and layout are read in place; anything else array-like (lists, float64,
//! a strided view) is converted once by numpy (`PyArrayLike`).

use glam::{Affine3A, Mat4, Vec3};
use numpy::{
    AllowTypeChange, PyArray1, PyArray2, PyArrayLike2, PyArrayMethods, PyUntypedArrayMethods,
};
use pyo3::exceptions::PyValueError;
use pyo3::prelude::*;

/// `obj`, or a copy of it when it is a numpy array that is not aligned (one unpickled
/// from a byte stream may not be): the array views read here need aligned memory.
pub fn aligned<'py>(obj: &Bound<'py, PyAny>) -> PyResult<Bound<'py, PyAny>> {
    match obj.getattr("flags").and_then(|f| f.getattr("aligned")) {
        Ok(a) if !a.extract::<bool>().unwrap_or(true) => obj.call_method0("copy"),
        _ => Ok(obj.clone()),
    }
}

/// `(N, 3)` float32 owning `v`'s memory.
pub fn vec3s<'py>(py: Python<'py>, v: Vec<Vec3>) -> PyResult<Bound<'py, PyArray2<f32>>> {
    let n = v.len();
    let flat: Vec<f32> = bytemuck::allocation::try_cast_vec(v)
        .unwrap_or_else(|(_, v)| v.iter().flat_map(|p| p.to_array()).collect());
    PyArray1::from_vec(py, flat).reshape([n, 3])
}

/// `(H, W, 3)` float32 owning `v`'s memory (row-major pixels from the top left).
pub fn image<'py>(
    py: Python<'py>,
    v: Vec<Vec3>,
    width: usize,
    height: usize,
) -> PyResult<Bound<'py, PyAny>> {
    let flat: Vec<f32> = bytemuck::allocation::try_cast_vec(v)
        .unwrap_or_else(|(_, v)| v.iter().flat_map(|p| p.to_array()).collect());
    Ok(PyArray1::from_vec(py, flat)
        .reshape([height, width, 3])?
        .into_any())
}

/// `(N, 3)` float32 (or anything numpy turns into one) as points / colours; `what` names
/// the array in errors.
pub fn read_vec3s(a: &PyArrayLike2<'_, f32, AllowTypeChange>, what: &str) -> PyResult<Vec<Vec3>> {
    let shape = a.shape();
    if shape[1] != 3 {
        return Err(PyValueError::new_err(format!(
            "{what} must have shape (N, 3), got {shape:?}"
        )));
    }
    let view = a.as_array();
    Ok(match view.as_slice() {
        Some(s) => bytemuck::cast_slice::<f32, Vec3>(s).to_vec(),
        None => view
            .rows()
            .into_iter()
            .map(|r| Vec3::new(r[0], r[1], r[2]))
            .collect(),
    })
}

/// `(M, 3)` vertex indices (`T` int64 or uint64, to which numpy casts the other integers).
pub fn read_triangles<T: numpy::Element + Copy + Into<i128>>(
    a: &PyArrayLike2<'_, T, AllowTypeChange>,
    vertices: usize,
    what: &str,
) -> PyResult<Vec<[u32; 3]>> {
    let shape = a.shape();
    if shape[1] != 3 {
        return Err(PyValueError::new_err(format!(
            "{what} must have shape (M, 3), got {shape:?}"
        )));
    }
    let view = a.as_array();
    let mut out = Vec::with_capacity(shape[0]);
    for (t, r) in view.rows().into_iter().enumerate() {
        let mut tri = [0u32; 3];
        for k in 0..3 {
            let i: i128 = r[k].into();
            if i < 0 || i >= vertices as i128 {
                return Err(PyValueError::new_err(format!(
                    "{what}: triangle {t} has vertex index {i} out of range ({vertices} vertices)"
                )));
            }
            tri[k] = i as u32;
        }
        out.push(tri);
    }
    Ok(out)
}

/// A 4x4 matrix (row-major as numpy prints it, column vectors: `p' = M @ [p, 1]`) as an
/// affine map; the last row must be `[0, 0, 0, 1]`.
pub fn read_affine(a: &PyArrayLike2<'_, f64, AllowTypeChange>, what: &str) -> PyResult<Affine3A> {
    let shape = a.shape();
    if shape != [4, 4] {
        return Err(PyValueError::new_err(format!(
            "{what} must be a 4x4 matrix, got shape {shape:?}"
        )));
    }
    let m = a.as_array();
    let last = [m[[3, 0]], m[[3, 1]], m[[3, 2]], m[[3, 3]]];
    if last != [0.0, 0.0, 0.0, 1.0] {
        return Err(PyValueError::new_err(format!(
            "{what} must be affine (last row [0, 0, 0, 1]), got last row {last:?}"
        )));
    }
    let cols: [f32; 16] = std::array::from_fn(|i| m[[i % 4, i / 4]] as f32);
    Ok(Affine3A::from_mat4(Mat4::from_cols_array(&cols)))
}

/// An affine map as a 4x4 float64 numpy matrix.
pub fn affine<'py>(py: Python<'py>, a: Affine3A) -> PyResult<Bound<'py, PyArray2<f64>>> {
    let m = Mat4::from(a);
    let rows: Vec<f64> = (0..16).map(|i| m.col(i % 4)[i / 4] as f64).collect();
    PyArray1::from_vec(py, rows).reshape([4, 4])
}
