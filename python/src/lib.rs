//! `kanedyn._kanedyn`, the native module of the `kanedyn` Python package.
//!
//! One Python module built from one file per stage of kanedyn's pipeline (see the root crate's
//! module doc); each stage's file has a `register` function that adds its classes and functions
//! here: the mechanism and its equations of motion, time runs (`simulate`), linear analysis
//! (`linear`), harmonic balance (`hbm`), studies (`study`) and their design studies' cases (`design`),
//! OpenTorsion assemblies (`opentorsion`); `arrays` holds the NumPy
//! conversions they share. The pure-Python package `kanedyn` re-exports what is public.
//!
//! Every entry point runs inside [`errors::guard`], so a Rust panic reaches Python as
//! `kanedyn.InternalError`, never as PyO3's `PanicException`.

use pyo3::prelude::*;

pub mod arrays;
pub mod design;
pub mod errors;
pub mod hbm;
pub mod linear;
pub mod mechanism;
pub mod opentorsion;
pub mod simulate;
pub mod study;

/// Native part of kanedyn: planar multibody dynamics by Kane's method, for torsional vibration.
/// Import `kanedyn`, not this module.
#[pymodule]
fn _kanedyn(m: &Bound<'_, PyModule>) -> PyResult<()> {
    m.add("__version__", env!("CARGO_PKG_VERSION"))?;
    errors::register(m)?;
    mechanism::register(m)?;
    simulate::register(m)?;
    linear::register(m)?;
    hbm::register(m)?;
    study::register(m)?;
    opentorsion::register(m)?;
    m.add_function(wrap_pyfunction!(panic_for_test, m)?)?;
    Ok(())
}

/// Panics inside the guard that every entry point uses, so the tests can check that a panic
/// becomes `kanedyn.InternalError` (no public call is known to panic). Not part of the API.
#[pyfunction]
#[pyo3(name = "_panic_for_test")]
fn panic_for_test(message: &str) -> PyResult<()> {
    errors::guard(|| panic!("{message}"))
}
