//! NumPy arrays in and out, shared by every module: new arrays from Rust numbers, and 1-D
//! sequences of numbers read from any array-like argument.

use crate::errors::argument_error;
use numpy::ndarray::Array2;
use numpy::{AllowTypeChange, Element, IntoPyArray, PyArray1, PyArray2, PyArrayLike1};
use pyo3::prelude::*;

/// A new 1-D float64 array holding `v`.
pub fn vector<'py>(py: Python<'py>, v: &[f64]) -> Bound<'py, PyArray1<f64>> {
    PyArray1::from_slice(py, v)
}

/// A new `rows × cols` array (C order) from the row-major `flat`.
pub fn matrix<'py, T: Element>(
    py: Python<'py>,
    rows: usize,
    cols: usize,
    flat: Vec<T>,
) -> PyResult<Bound<'py, PyArray2<T>>> {
    let a = Array2::from_shape_vec((rows, cols), flat)
        .map_err(|e| pyo3::exceptions::PyRuntimeError::new_err(format!("array of {rows}×{cols}: {e}")))?;
    Ok(a.into_pyarray(py))
}

/// A new float64 array holding the nalgebra matrix `m`, row for row.
pub fn dmatrix<'py>(py: Python<'py>, m: &nalgebra::DMatrix<f64>) -> PyResult<Bound<'py, PyArray2<f64>>> {
    let (r, c) = m.shape();
    matrix(py, r, c, (0..r).flat_map(|i| (0..c).map(move |j| m[(i, j)])).collect())
}

/// A new float64 array holding the nalgebra vector `v`.
pub fn dvector<'py>(py: Python<'py>, v: &nalgebra::DVector<f64>) -> Bound<'py, PyArray1<f64>> {
    PyArray1::from_slice(py, v.as_slice())
}

/// Reads a 1-D sequence of finite numbers (any array-like; a float64 array is read in place),
/// naming the argument `name` in the error.
pub fn read_finite(py: Python<'_>, name: &str, values: &Bound<'_, PyAny>) -> PyResult<Vec<f64>> {
    let array: PyArrayLike1<'_, f64, AllowTypeChange> =
        values.extract().map_err(|e| argument_error(py, format!("{name} must be a 1-D sequence of numbers ({e})")))?;
    let out: Vec<f64> = array.as_array().iter().copied().collect();
    if let Some(i) = out.iter().position(|v| !v.is_finite()) {
        return Err(argument_error(py, format!("{name}[{i}] is not finite ({})", out[i])));
    }
    Ok(out)
}

/// Refuses a number that is not finite (or not positive when `positive`), naming it.
/// A limit the command line applies too (`kanedyn::study::validate::limits`, one function for
/// both): its reason as an `ArgumentError` naming the argument.
pub fn limit(py: Python<'_>, name: &str, check: Result<(), String>) -> PyResult<()> {
    check.map_err(|reason| argument_error(py, format!("{name}: {reason} (the limit of the kanedyn command line)")))
}

pub fn check_number(py: Python<'_>, name: &str, v: f64, positive: bool) -> PyResult<()> {
    if !v.is_finite() || (positive && v <= 0.0) {
        let what = if positive { "a finite, positive number" } else { "finite" };
        return Err(argument_error(py, format!("{name} must be {what}, got {v}")));
    }
    Ok(())
}
