//! Solver settings from Python keyword arguments: the library's keys
//! (`shrad::settings`), with values given as Python numbers, booleans or strings.

use pyo3::exceptions::PyValueError;
use pyo3::prelude::*;
use pyo3::types::{PyBool, PyDict, PyFloat, PyInt, PyString};
use shrad::solver::SolverChoice;

/// A Python value as the text a setting parses (`True` -> `true`, `0.5` -> `0.5`). numpy
/// scalars count as the numbers they are (`np.int64(16)`, `np.float32(0.5)`, `np.bool_`),
/// as a sweep over `np.arange(...)` gives them.
pub fn value_text(key: &str, v: &Bound<'_, PyAny>) -> PyResult<String> {
    let ty = v.get_type().name()?.to_string();
    if v.is_instance_of::<PyBool>() || ty == "bool" || ty == "bool_" {
        return Ok(if v.is_truthy()? { "true" } else { "false" }.to_string());
    }
    if v.is_instance_of::<PyInt>()
        || v.is_instance_of::<PyFloat>()
        || v.is_instance_of::<PyString>()
    {
        return Ok(v.str()?.to_string());
    }
    // An integer type (`__index__`) as its int, a real one (`__float__`) as its float.
    if v.hasattr("__index__")? {
        return Ok(v.call_method0("__index__")?.str()?.to_string());
    }
    if v.hasattr("__float__")? && !ty.contains("complex") {
        return Ok(v.call_method0("__float__")?.str()?.to_string());
    }
    Err(PyValueError::new_err(format!(
        "setting {key}: expected a number, a bool or a string, got {ty}"
    )))
}

/// `(key, text)` pairs of a dict of settings.
pub fn pairs(settings: Option<&Bound<'_, PyDict>>) -> PyResult<Vec<(String, String)>> {
    let mut out = Vec::new();
    for (k, v) in settings.into_iter().flat_map(|d| d.iter()) {
        let k: String = k.extract()?;
        let text = value_text(&k, &v)?;
        out.push((k, text));
    }
    Ok(out)
}

/// The solver `solver` at `preset` with `settings` applied (all or nothing).
pub fn choice(
    solver: &str,
    preset: &str,
    settings: Option<&Bound<'_, PyDict>>,
) -> PyResult<SolverChoice> {
    let mut choice = SolverChoice::preset(solver, preset).map_err(crate::to_py_err)?;
    choice
        .set_all(&pairs(settings)?)
        .map_err(crate::to_py_err)?;
    Ok(choice)
}

/// Every setting of `solver` (`"dispersive"`, `"grid"` or `"reference"`; all three when
/// None) as dicts: `solver`, `name`, `doc`, `range`, `rebuilds` (changing it runs the
/// precomputation again) and `defaults` (`{preset: value}`, the default preset first). The
/// same table as `shrad options`.
#[pyfunction]
#[pyo3(signature = (solver=None))]
pub fn options<'py>(py: Python<'py>, solver: Option<&str>) -> PyResult<Vec<Bound<'py, PyDict>>> {
    let solvers: Vec<&str> = match solver {
        Some(s) => vec![s],
        None => shrad::settings::SOLVERS.to_vec(),
    };
    let mut out = Vec::new();
    for s in solvers {
        for k in shrad::settings::describe(s).map_err(crate::to_py_err)? {
            let d = PyDict::new(py);
            d.set_item("solver", s)?;
            d.set_item("name", k.name)?;
            d.set_item("doc", k.doc)?;
            d.set_item("range", k.range)?;
            d.set_item("rebuilds", k.rebuilds)?;
            let defaults = PyDict::new(py);
            for (p, v) in k.defaults {
                defaults.set_item(p, v)?;
            }
            d.set_item("defaults", defaults)?;
            out.push(d);
        }
    }
    Ok(out)
}
