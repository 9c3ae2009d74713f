//! `shrad._shrad`, the native half of the Python package `shrad` (PyO3): scenes
//! (`scene`), the live engine (`engine`), pictures (`images`). The Python half
//! (`python/shrad/`) adds `sweep` and re-exports everything here.
//!
//! Errors: a bad input is a `ValueError`, a file that cannot be read or written an
//! `OSError`, each with the message the CLI prints (it names the file and what is wrong).
//! Ctrl-C stops the long calls (`stop`).

use pyo3::exceptions::{
    PyFileNotFoundError, PyKeyboardInterrupt, PyOSError, PyPermissionError, PyValueError,
};
use pyo3::prelude::*;
use pyo3::types::{PyDict, PyList};

mod args;
mod arrays;
mod engine;
mod images;
mod scene;
mod scene_dict;
mod settings;
mod stop;

/// A library error as the Python exception a user expects: `OSError` for files that
/// cannot be read or written, `KeyboardInterrupt` for work stopped (`stop`), `ValueError`
/// for everything else.
pub(crate) fn to_py_err(e: shrad::Error) -> PyErr {
    use shrad::scene::SceneError;
    let message = e.to_string();
    match e {
        shrad::Error::Scene(SceneError::Io { source, .. }) => {
            // The OS's reason after the file ("cornell.glb: cannot read file: No such file").
            os_error(source.kind(), format!("{message}: {source}"))
        }
        // A file the scene names (a glTF's .bin, a scene file's mesh or sky): the message
        // names both and the reason.
        shrad::Error::Scene(SceneError::Unreadable { kind, .. }) => os_error(kind, message),
        // A file that cannot be written, however it was reached: the message names it
        // ("out.glb: cannot write: ...").
        shrad::Error::Scene(SceneError::Write(_))
        | shrad::Error::Input(..)
        | shrad::Error::Output(..) => PyOSError::new_err(message),
        // Listed, not `_`: a new kind of error has to be sorted into one or the other.
        shrad::Error::Scene(SceneError::Invalid { .. } | SceneError::UnknownFormat { .. })
        | shrad::Error::Invalid(_) => PyValueError::new_err(message),
        // What `stop::interruptible` asked for after a signal handler raised; it raises that
        // handler's exception, so this one is seen only if the library stops by itself.
        shrad::Error::Interrupted => PyKeyboardInterrupt::new_err(message),
    }
}

/// The `OSError` subclass Python's own `open` raises for `kind`.
fn os_error(kind: std::io::ErrorKind, message: String) -> PyErr {
    match kind {
        std::io::ErrorKind::NotFound => PyFileNotFoundError::new_err(message),
        std::io::ErrorKind::PermissionDenied => PyPermissionError::new_err(message),
        _ => PyOSError::new_err(message),
    }
}

/// A JSON value (statistics serialised by serde) as the Python object it reads as.
pub(crate) fn json_to_py<'py>(
    py: Python<'py>,
    v: &serde_json::Value,
) -> PyResult<Bound<'py, PyAny>> {
    use serde_json::Value;
    Ok(match v {
        Value::Null => py.None().into_bound(py),
        Value::Bool(b) => b.into_pyobject(py)?.to_owned().into_any(),
        Value::Number(n) => match (n.as_i64(), n.as_u64()) {
            (Some(i), _) => i.into_pyobject(py)?.into_any(),
            (None, Some(u)) => u.into_pyobject(py)?.into_any(),
            _ => n.as_f64().unwrap_or(f64::NAN).into_pyobject(py)?.into_any(),
        },
        Value::String(s) => s.into_pyobject(py)?.into_any(),
        Value::Array(items) => {
            let list = PyList::empty(py);
            for item in items {
                list.append(json_to_py(py, item)?)?;
            }
            list.into_any()
        }
        Value::Object(map) => {
            let dict = PyDict::new(py);
            for (k, item) in map {
                dict.set_item(k, json_to_py(py, item)?)?;
            }
            dict.into_any()
        }
    })
}

/// Any serialisable value (frame statistics, errors) as a Python dict / list / number.
pub(crate) fn to_py<'py, T: serde::Serialize>(
    py: Python<'py>,
    v: &T,
) -> PyResult<Bound<'py, PyAny>> {
    let json = serde_json::to_value(v).map_err(|e| PyValueError::new_err(e.to_string()))?;
    json_to_py(py, &json)
}

/// The native module `shrad._shrad`.
#[pymodule]
fn _shrad(m: &Bound<'_, PyModule>) -> PyResult<()> {
    m.add_class::<scene::PyScene>()?;
    m.add_class::<scene::PyObjectInfo>()?;
    m.add_class::<engine::PyEngine>()?;
    m.add_function(wrap_pyfunction!(scene::load, m)?)?;
    m.add_function(wrap_pyfunction!(scene_dict::load_dict, m)?)?;
    m.add_function(wrap_pyfunction!(scene::builtins, m)?)?;
    m.add_function(wrap_pyfunction!(images::write_exr, m)?)?;
    m.add_function(wrap_pyfunction!(images::write_png, m)?)?;
    m.add_function(wrap_pyfunction!(images::read_exr, m)?)?;
    m.add_function(wrap_pyfunction!(settings::options, m)?)?;
    m.add("__version__", env!("CARGO_PKG_VERSION"))?;
    Ok(())
}
