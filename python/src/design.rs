//! Design studies from Python: a study's case tables as NumPy arrays, and cases run by index so
//! that `kanedyn.dask` can spread them over a cluster.
//!
//! A case is a pure function of the study and its index (`kanedyn::study::design`), so rows run
//! here, one by one on Dask workers or all at once with rayon, are the same numbers bit for bit;
//! [`table`] and `kanedyn/dask.py` assemble them into the same arrays.

use crate::errors::{argument_error, guard, to_py};
use kanedyn::study::Study as LibStudy;
use kanedyn::study::design::{self, CaseRow, DesignResult, DesignSpec};
use numpy::PyArray1;
use pyo3::prelude::*;
use pyo3::types::{PyDict, PyList};

/// The design study `name` of `study` with the study its cases run on (the study itself, or the
/// study of the design study's own `mechanism`), or an `ArgumentError` naming the ones there are.
pub fn spec<'a>(py: Python<'_>, study: &'a LibStudy, name: &str) -> PyResult<(&'a LibStudy, &'a DesignSpec)> {
    design::find(study, name).ok_or_else(|| {
        let names = names(study);
        argument_error(
            py,
            format!(
                "no design study `{name}` in study `{}` (design studies: {})",
                study.spec.name,
                if names.is_empty() { "none".to_string() } else { names.join(", ") }
            ),
        )
    })
}

/// The names of the study's design studies, in file order.
pub fn names(study: &LibStudy) -> Vec<String> {
    study.spec.analyses.iter().filter(|a| a.kind() == "DesignStudy").map(|a| a.name().to_string()).collect()
}

/// `{"parameters": [(column, unit)], "results": [(column, unit)]}` of a design study.
pub fn columns<'py>(py: Python<'py>, study: &LibStudy, spec: &DesignSpec) -> PyResult<Bound<'py, PyDict>> {
    let d = PyDict::new(py);
    let pairs = |cols: Vec<design::ColumnInfo>| cols.into_iter().map(|c| (c.name, c.unit)).collect::<Vec<_>>();
    d.set_item("parameters", pairs(design::parameter_columns(study, spec)))?;
    d.set_item("results", pairs(design::result_columns(study, spec)))?;
    Ok(d)
}

/// Runs the cases `indices` (every case when None), in parallel with rayon when `parallel`, with
/// the interpreter released, and returns their rows as dicts: `case` (int), `values` and
/// `results` (lists of float, NaN where none exists), `status` (`ok`, `partial`, `failed`),
/// `error` (str).
pub fn run_cases<'py>(
    py: Python<'py>,
    study: &LibStudy,
    spec: &DesignSpec,
    indices: Option<Vec<usize>>,
    parallel: bool,
) -> PyResult<Bound<'py, PyList>> {
    guard(|| {
        let rows = py
            .detach(|| design::run_cases(study, spec, indices.as_deref(), parallel, &|| {}))
            .map_err(|e| to_py(py, &e))?;
        let list = PyList::empty(py);
        for r in &rows {
            list.append(row(py, r)?)?;
        }
        Ok(list)
    })
}

/// One row as a dict.
fn row<'py>(py: Python<'py>, r: &CaseRow) -> PyResult<Bound<'py, PyDict>> {
    let d = PyDict::new(py);
    d.set_item("case", r.index)?;
    d.set_item("values", &r.values)?;
    d.set_item("results", &r.results)?;
    d.set_item("status", r.status.as_str())?;
    d.set_item("error", &r.error)?;
    Ok(d)
}

/// A design study's case table as arrays: `case`, the parameter and result columns (float64,
/// NaN where none exists), `status` and `error` (NumPy string arrays).
pub fn table<'py>(py: Python<'py>, r: &DesignResult) -> PyResult<Bound<'py, PyDict>> {
    let d = PyDict::new(py);
    for c in r.table().columns {
        d.set_item(&c.name, PyArray1::from_slice(py, &c.values))?;
    }
    let np = py.import("numpy")?;
    let strings = |f: &dyn Fn(&CaseRow) -> String| r.cases.iter().map(f).collect::<Vec<String>>();
    d.set_item("status", np.call_method1("array", (strings(&|c| c.status.as_str().to_string()),))?)?;
    d.set_item("error", np.call_method1("array", (strings(&|c| c.error.clone()),))?)?;
    Ok(d)
}

/// Every design study's table of a study run (its `designs`), by name.
pub fn tables<'py>(py: Python<'py>, designs: &[DesignResult]) -> PyResult<Bound<'py, PyDict>> {
    let out = PyDict::new(py);
    for r in designs {
        out.set_item(&r.name, table(py, r)?)?;
    }
    Ok(out)
}
