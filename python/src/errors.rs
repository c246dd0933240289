//! Python exceptions for kanedyn's errors, and the guard that keeps a Rust panic from reaching
//! Python.
//!
//! Every error is a `kanedyn.KanedynError`, one subclass per error class of the library
//! (`kanedyn::error::Error`), so a script can catch all of kanedyn's failures at once or one kind
//! of them. The message is the one the command-line tool prints after `error: `, so a file's
//! mistake reads the same in a notebook as in a terminal (file, line:column, field).

use kanedyn::error::Error;
use pyo3::create_exception;
use pyo3::exceptions::{PyException, PyValueError};
use pyo3::prelude::*;
use pyo3::sync::PyOnceLock;
use pyo3::types::PyType;
use std::panic::{AssertUnwindSafe, catch_unwind};

create_exception!(
    kanedyn,
    KanedynError,
    PyException,
    "Base class of every error kanedyn raises.\n\n`str(err)` is the message the `kanedyn` command-line tool prints after `error: `."
);
create_exception!(
    kanedyn,
    InputError,
    KanedynError,
    "Bad input in a mechanism file or text: a syntax error, an unknown field, a wrong type, a\n\
     semantic problem, a file too large or not a regular file.\n\n\
     Attributes: `file` (str); `line` and `column` (1-based int, None when unknown); `field`\n\
     (the field path such as `joints[1].parent`, empty for the whole file); `reason` (the\n\
     message without its location)."
);
create_exception!(
    kanedyn,
    LimitError,
    InputError,
    "Input refused by a limit that can be raised on purpose: a file over the size cap, more bodies\n\
     than the body cap, a study whose estimated memory, output or CPU time exceeds its limit. The\n\
     message names the option that raises it.\n\n\
     A subclass of `InputError` (code that catches that still catches this), with its attributes."
);
create_exception!(
    kanedyn,
    ReadError,
    KanedynError,
    "A file could not be read (missing, not a regular file, no permission).\n\nAttribute: `file` (str)."
);
create_exception!(
    kanedyn,
    ModelError,
    KanedynError,
    "A mechanism that parses but cannot be evaluated.\n\nAttribute: `mechanism` (its name)."
);
create_exception!(
    kanedyn,
    EngineError,
    KanedynError,
    "A failure while evaluating the equations of motion (a mass matrix that is not positive \
     definite at this state, a non-finite value, an overflow)."
);
create_exception!(
    kanedyn,
    InternalError,
    KanedynError,
    "A bug in kanedyn: the Rust code panicked. The objects involved stay usable; please report\n\
     the message with the input that caused it."
);

/// `kanedyn.ArgumentError`, built at module load because it has two bases (`KanedynError` and
/// `ValueError`), which `create_exception!` cannot express.
static ARGUMENT_ERROR: PyOnceLock<Py<PyType>> = PyOnceLock::new();

const ARGUMENT_ERROR_DOC: &str = "A bad argument to a kanedyn call: an array of the wrong length, a\n\
     non-finite number, an unknown joint name.\n\n\
     It is also a `ValueError`, so code that catches either works.";

/// The `ArgumentError` type, created on first use.
fn argument_error_type(py: Python<'_>) -> PyResult<&Bound<'_, PyType>> {
    let ty = ARGUMENT_ERROR.get_or_try_init(py, || -> PyResult<Py<PyType>> {
        let bases = (py.get_type::<KanedynError>(), py.get_type::<PyValueError>());
        let namespace = pyo3::types::PyDict::new(py);
        namespace.set_item("__module__", "kanedyn")?;
        namespace.set_item("__doc__", ARGUMENT_ERROR_DOC)?;
        let ty = py.get_type::<PyType>().call1(("ArgumentError", bases, namespace))?;
        Ok(ty.cast_into::<PyType>()?.unbind())
    })?;
    Ok(ty.bind(py))
}

/// A `kanedyn.ArgumentError` with `message`.
pub fn argument_error(py: Python<'_>, message: impl Into<String>) -> PyErr {
    match argument_error_type(py) {
        Ok(ty) => PyErr::from_type(ty.clone(), message.into()),
        Err(e) => e,
    }
}

/// Adds the exception types to the module.
pub fn register(m: &Bound<'_, PyModule>) -> PyResult<()> {
    let py = m.py();
    m.add("KanedynError", py.get_type::<KanedynError>())?;
    m.add("InputError", py.get_type::<InputError>())?;
    m.add("LimitError", py.get_type::<LimitError>())?;
    m.add("ReadError", py.get_type::<ReadError>())?;
    m.add("ModelError", py.get_type::<ModelError>())?;
    m.add("EngineError", py.get_type::<EngineError>())?;
    m.add("InternalError", py.get_type::<InternalError>())?;
    m.add("ArgumentError", argument_error_type(py)?)?;
    Ok(())
}

/// A `kanedyn.ModelError` about mechanism `mechanism` (also its attribute), with `message`.
pub fn model_error(py: Python<'_>, mechanism: &str, message: impl Into<String>) -> PyErr {
    let err = ModelError::new_err(message.into());
    // As in `to_py`: the attribute is a convenience; failing to set it must not hide the error.
    let _ = err.value(py).setattr("mechanism", mechanism);
    err
}

/// The error and its causes joined by `: `, leaving out a cause whose text is already there:
/// the command-line tool's rule (`without_repeats` in src/bin/kanedyn.rs), so that a message
/// reads the same in Python. An I/O error, for one, names its OS reason and also reports it as
/// its source.
pub fn message_of(e: &(dyn std::error::Error + 'static)) -> String {
    let mut out = String::new();
    let mut cause = Some(e);
    while let Some(c) = cause {
        let text = c.to_string();
        if !out.contains(&text) {
            if !out.is_empty() {
                out += ": ";
            }
            out += &text;
        }
        cause = c.source();
    }
    out
}

/// The Python exception for a library error, with its location as attributes.
pub fn to_py(py: Python<'_>, e: &Error) -> PyErr {
    let message = message_of(e);
    let err = match e {
        Error::Input { .. } => InputError::new_err(message),
        Error::Limit { .. } => LimitError::new_err(message),
        Error::Io { .. } => ReadError::new_err(message),
        Error::Model { .. } => ModelError::new_err(message),
        Error::Engine(_) => EngineError::new_err(message),
    };
    // Attributes are a convenience on top of the message; failing to set one must not hide
    // the error itself.
    let _ = set_attributes(err.value(py), e);
    err
}

fn set_attributes(value: &Bound<'_, pyo3::exceptions::PyBaseException>, e: &Error) -> PyResult<()> {
    match e {
        Error::Input { location, message } | Error::Limit { location, message } => {
            value.setattr("file", location.file.display().to_string())?;
            value.setattr("line", location.line_col.map(|(l, _)| l))?;
            value.setattr("column", location.line_col.map(|(_, c)| c))?;
            value.setattr("field", &location.path)?;
            value.setattr("reason", message)?;
        }
        Error::Io { file, .. } => value.setattr("file", file.display().to_string())?,
        Error::Model { mechanism, .. } => value.setattr("mechanism", mechanism)?,
        Error::Engine(_) => {}
    }
    Ok(())
}

/// Runs `f`, turning a Rust panic into `kanedyn.InternalError`.
///
/// Every entry point from Python goes through here. Without it, PyO3 would raise its
/// `PanicException`, which derives from `BaseException`: `except Exception` would not catch it
/// and a notebook kernel or a worker would die with it.
///
/// `AssertUnwindSafe` is sound here because the only state kept across calls (a mechanism's
/// cached evaluator) sits behind a mutex that a panic poisons, and a poisoned cache is thrown
/// away and rebuilt, never read (see `mechanism.rs`).
pub fn guard<T>(f: impl FnOnce() -> PyResult<T>) -> PyResult<T> {
    match catch_unwind(AssertUnwindSafe(f)) {
        Ok(result) => result,
        Err(payload) => {
            let what = payload
                .downcast_ref::<&str>()
                .map(|s| s.to_string())
                .or_else(|| payload.downcast_ref::<String>().cloned())
                .unwrap_or_else(|| "(no message)".to_string());
            Err(InternalError::new_err(format!(
                "internal error in kanedyn (a bug; please report it with the input that caused it): {what}"
            )))
        }
    }
}
