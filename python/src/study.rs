//! `kanedyn.Study`: a study file loaded and run as `kanedyn run` does, its results as the data
//! of `results.json` with the CSV columns as NumPy arrays.
//!
//! `run` calls the library's `study::run` (which writes the CSV, SVG, `summary.md` and
//! `results.json` files) and builds the result from `study::json::document`, the very document
//! `results.json` holds, so the two are the same data. Without an output folder the files go to
//! a fresh temporary folder that is removed afterwards.

use crate::errors::{argument_error, guard, to_py};
use crate::mechanism::Mechanism;
use kanedyn::io::ReadPolicy;
use kanedyn::study::json::{Document, document};
use kanedyn::study::{Limits, LoadOptions, RunOptions, Study as LibStudy, StudyReport, run};
use numpy::PyArray1;
use pyo3::prelude::*;
use pyo3::types::{PyDict, PyList, PyTuple};
use serde_json::Value;
use std::path::PathBuf;
use std::sync::atomic::{AtomicUsize, Ordering};

/// Adds `Study` and `StudyResult` to the module.
pub fn register(m: &Bound<'_, PyModule>) -> PyResult<()> {
    m.add_class::<Study>()?;
    m.add_class::<StudyResult>()
}

/// The CLI's defaults, written as literals in the Python signature so that `help()` shows them.
const _: () = assert!(ReadPolicy::DEFAULT_MAX_BODIES == 1000 && ReadPolicy::DEFAULT_MAX_FILE_BYTES == 1024 * 1024);

/// A study file read and checked whole, ready to run: its mechanism, the locked twin and the
/// analyses (see the README's study file format).
#[pyclass(module = "kanedyn", frozen)]
pub struct Study {
    study: LibStudy,
    /// The load options, kept so that a pickled study loads the same way again.
    options: PickleOptions,
}

/// The keyword arguments of `from_file`/`from_str`, as given.
#[derive(Clone)]
struct PickleOptions {
    /// The study file's name made absolute when it was loaded (a worker with another working
    /// folder then resolves the mechanism the same way).
    file: String,
    allow_read: Vec<PathBuf>,
    allow_any_path: bool,
    max_file_kb: u64,
    max_bodies: usize,
    max_memory_mb: f64,
    max_output_mb: f64,
    max_cpu_hours: f64,
}

impl PickleOptions {
    /// The library's load options (limits in bytes and seconds); refuses a limit that is not a
    /// finite, positive number, as the CLI does (LimitArgs::options in src/bin/kanedyn.rs).
    fn load_options(&self, py: Python<'_>) -> PyResult<LoadOptions> {
        for (name, v) in [
            ("max_memory_mb", self.max_memory_mb),
            ("max_output_mb", self.max_output_mb),
            ("max_cpu_hours", self.max_cpu_hours),
        ] {
            if !(v.is_finite() && v > 0.0) {
                return Err(argument_error(py, format!("{name} must be a finite, positive number, got {v}")));
            }
        }
        let mb = 1024.0 * 1024.0;
        Ok(LoadOptions {
            limits: Limits {
                max_memory_bytes: self.max_memory_mb * mb,
                max_output_bytes: self.max_output_mb * mb,
                max_cpu_s: self.max_cpu_hours * 3600.0,
                ..Limits::default()
            },
            allow_read: self.allow_read.clone(),
            allow_any_path: self.allow_any_path,
            max_file_bytes: self.max_file_kb.saturating_mul(1024),
            max_bodies: self.max_bodies,
        })
    }
}

#[pymethods]
impl Study {
    /// Reads a study file and its mechanism and checks everything ``kanedyn run`` checks before
    /// any work: names, fields, order-tracking bands and the estimated work against the limits.
    ///
    /// Parameters
    /// ----------
    /// path : str or os.PathLike
    ///     The study file (RON).
    /// allow_read : list of paths, optional
    ///     Further folders its mechanism and parts may be read from, as ``--allow-read DIR``.
    /// allow_any_path : bool, default False
    ///     Read them from any path, as ``--allow-any-path``.
    /// max_file_kb : int, default 1024
    ///     Largest input file, kB (``--max-file-kb``).
    /// max_bodies : int, default 1000
    ///     Most bodies in the mechanism (``--max-bodies``).
    /// max_memory_mb, max_output_mb : float, default 2048.0
    ///     Largest estimated memory and output size, MB (``--max-memory-mb``,
    ///     ``--max-output-mb``).
    /// max_cpu_hours : float, default 12.0
    ///     Largest estimated CPU time, h (``--max-cpu-hours``).
    ///
    /// Returns
    /// -------
    /// Study
    ///
    /// Raises
    /// ------
    /// ReadError, InputError, ModelError
    ///     As ``kanedyn check STUDY`` reports them, located at file, line:column and field.
    /// ArgumentError
    ///     A limit that is not a finite, positive number.
    #[staticmethod]
    #[pyo3(signature = (
        path, *, allow_read = None, allow_any_path = false, max_file_kb = 1024, max_bodies = 1000,
        max_memory_mb = 2048.0, max_output_mb = 2048.0, max_cpu_hours = 12.0
    ))]
    #[allow(clippy::too_many_arguments)]
    fn from_file(
        py: Python<'_>,
        path: PathBuf,
        allow_read: Option<Vec<PathBuf>>,
        allow_any_path: bool,
        max_file_kb: u64,
        max_bodies: usize,
        max_memory_mb: f64,
        max_output_mb: f64,
        max_cpu_hours: f64,
    ) -> PyResult<Self> {
        guard(|| {
            let options = PickleOptions {
                file: crate::mechanism::absolute(&path),
                allow_read: allow_read.unwrap_or_default(),
                allow_any_path,
                max_file_kb,
                max_bodies,
                max_memory_mb,
                max_output_mb,
                max_cpu_hours,
            };
            let study = LibStudy::from_file_with(&path, &options.load_options(py)?).map_err(|e| to_py(py, &e))?;
            Ok(Self { study, options })
        })
    }

    /// Parses and checks study text as ``from_file`` checks a file; its mechanism is read
    /// relative to ``name``'s folder (the current folder for a bare name).
    ///
    /// Parameters
    /// ----------
    /// text : str
    ///     The study, as a file would hold it.
    /// name : str, default "<string>"
    ///     The file name that messages give and the mechanism is found from.
    /// allow_read, allow_any_path, max_file_kb, max_bodies, max_memory_mb, max_output_mb, max_cpu_hours
    ///     As for ``Study.from_file``.
    ///
    /// Returns
    /// -------
    /// Study
    ///
    /// Raises
    /// ------
    /// ReadError, InputError, ModelError, ArgumentError
    ///     As for ``Study.from_file``.
    #[staticmethod]
    #[pyo3(name = "from_str", signature = (
        text, name = "<string>", *, allow_read = None, allow_any_path = false, max_file_kb = 1024,
        max_bodies = 1000, max_memory_mb = 2048.0, max_output_mb = 2048.0, max_cpu_hours = 12.0
    ))]
    #[allow(clippy::too_many_arguments)]
    fn from_text(
        py: Python<'_>,
        text: &str,
        name: &str,
        allow_read: Option<Vec<PathBuf>>,
        allow_any_path: bool,
        max_file_kb: u64,
        max_bodies: usize,
        max_memory_mb: f64,
        max_output_mb: f64,
        max_cpu_hours: f64,
    ) -> PyResult<Self> {
        guard(|| {
            let options = PickleOptions {
                file: crate::mechanism::absolute(std::path::Path::new(name)),
                allow_read: allow_read.unwrap_or_default(),
                allow_any_path,
                max_file_kb,
                max_bodies,
                max_memory_mb,
                max_output_mb,
                max_cpu_hours,
            };
            let src = kanedyn::io::Source::from_text(name, text);
            let study = LibStudy::from_source(src, &options.load_options(py)?).map_err(|e| to_py(py, &e))?;
            Ok(Self { study, options })
        })
    }

    /// Pickling: the study's text, its file name (made absolute when it was loaded, so that a
    /// worker with another working folder resolves the mechanism the same way) and the load
    /// options; unpickling parses the
    /// text again (``Study.from_str``) and reads the mechanism from the file system relative to
    /// that name, so a worker on another machine needs the mechanism file at the same path (a
    /// shared file system).
    fn __reduce__<'py>(&self, py: Python<'py>) -> PyResult<(Bound<'py, PyAny>, Bound<'py, PyTuple>)> {
        let restore = py.import("kanedyn._pickle")?.getattr("restore_study")?;
        let o = &self.options;
        let allow_read: Vec<String> = o.allow_read.iter().map(|p| p.display().to_string()).collect();
        let args = (
            self.study.source.text.as_str(),
            o.file.as_str(),
            allow_read,
            o.allow_any_path,
            o.max_file_kb,
            o.max_bodies,
            o.max_memory_mb,
            o.max_output_mb,
            o.max_cpu_hours,
        )
            .into_pyobject(py)?;
        Ok((restore, args))
    }

    /// The names of the study's design studies (``DesignStudy`` analyses), in file order.
    #[getter]
    fn design_studies(&self) -> Vec<String> {
        crate::design::names(&self.study)
    }

    /// The columns of a design study's case table.
    ///
    /// Returns
    /// -------
    /// dict
    ///     ``parameters`` and ``results``: lists of ``(column, unit)`` in the table's order
    ///     (after ``case``; ``status`` and ``error`` follow).
    fn design_columns<'py>(&self, py: Python<'py>, name: &str) -> PyResult<Bound<'py, PyDict>> {
        guard(|| {
            let (study, spec) = crate::design::spec(py, &self.study, name)?;
            crate::design::columns(py, study, spec)
        })
    }

    /// The number of cases of a design study.
    fn case_count(&self, py: Python<'_>, name: &str) -> PyResult<usize> {
        guard(|| Ok(kanedyn::study::design::case_count(crate::design::spec(py, &self.study, name)?.1)))
    }

    /// Every case's parameter values, in the parameters' units: an array of shape (cases,
    /// parameters), row i the values of case i (the grid's combinations in order, or the seeded
    /// draws of a Latin hypercube or Monte Carlo).
    fn case_values<'py>(&self, py: Python<'py>, name: &str) -> PyResult<Bound<'py, numpy::PyArray2<f64>>> {
        guard(|| {
            let spec = crate::design::spec(py, &self.study, name)?.1;
            let rows = kanedyn::study::design::case_values(spec);
            let d = spec.parameters.len();
            crate::arrays::matrix(py, rows.len(), d, rows.into_iter().flatten().collect())
        })
    }

    /// Runs cases of a design study by index, without writing anything: what ``run`` computes
    /// for them, bit for bit (a case depends on its index alone). ``kanedyn.dask`` maps chunks
    /// of indices to workers with it.
    ///
    /// Parameters
    /// ----------
    /// name : str
    ///     The design study.
    /// indices : list of int, optional
    ///     Case indices from 0; every case when None.
    /// parallel : bool, default True
    ///     Run them in parallel with rayon (False: one after the other on this thread).
    ///
    /// Returns
    /// -------
    /// list of dict
    ///     One per index, in the order given: ``case``, ``values`` (the parameter values),
    ///     ``results`` (NaN where none exists), ``status`` (``ok``, ``partial``, ``failed``),
    ///     ``error`` (why, empty when ok). A failed case never raises.
    ///
    /// Raises
    /// ------
    /// ArgumentError
    ///     No design study of that name.
    /// ModelError
    ///     An index beyond the last case.
    #[pyo3(signature = (name, indices = None, *, parallel = true))]
    fn run_cases<'py>(
        &self,
        py: Python<'py>,
        name: &str,
        indices: Option<Vec<usize>>,
        parallel: bool,
    ) -> PyResult<Bound<'py, PyList>> {
        let (study, spec) = guard(|| crate::design::spec(py, &self.study, name))?;
        crate::design::run_cases(py, study, spec, indices, parallel)
    }

    /// The study's name (its output folder).
    #[getter]
    fn name(&self) -> &str {
        &self.study.spec.name
    }

    /// The study file.
    #[getter]
    fn file(&self) -> String {
        self.study.file.display().to_string()
    }

    /// The study's mechanism.
    #[getter]
    fn mechanism(&self) -> Mechanism {
        Mechanism::new(self.study.mechanism.clone())
    }

    /// The analyses as ``(kind, name)`` pairs, in the file's order.
    #[getter]
    fn analyses(&self) -> Vec<(&'static str, String)> {
        self.study.spec.analyses.iter().map(|a| (a.kind(), a.name().to_string())).collect()
    }

    /// Runs every analysis, as ``kanedyn run`` does: independent runs in parallel, one failure
    /// never costing the others (it is listed in ``failures``).
    ///
    /// Parameters
    /// ----------
    /// out : str or os.PathLike, optional
    ///     Output root: the CSV, SVG, ``summary.md`` and ``results.json`` files go to
    ///     ``out/<study name>/``, as ``kanedyn run --out``. None: they are written to a temporary
    ///     folder and removed; the result holds every number all the same.
    ///
    /// Returns
    /// -------
    /// StudyResult
    ///     ``tables`` (the CSV files' columns as arrays, equal to them), ``data`` (the document
    ///     ``results.json`` holds), ``summary``, ``failures``, ``status``.
    ///
    /// Raises
    /// ------
    /// ReadError, ModelError
    ///     The output folder cannot be prepared or moved into place, or another run holds it.
    #[pyo3(signature = (out = None))]
    fn run(&self, py: Python<'_>, out: Option<PathBuf>) -> PyResult<StudyResult> {
        guard(|| {
            let (root, temporary) = match out {
                Some(o) => (o, false),
                None => (temporary_folder(py)?, true),
            };
            let study = &self.study;
            let opts = RunOptions { out: Some(root.clone()), progress: false };
            let report = py.detach(|| run(study, &opts));
            let result = report.map_err(|e| to_py(py, &e)).and_then(|report| {
                let doc = document(study, &report);
                let files =
                    if temporary { Vec::new() } else { report.files.iter().map(|f| f.display().to_string()).collect() };
                let out_dir = (!temporary).then(|| root.join(&study.spec.name).display().to_string());
                StudyResult::new(py, &doc, &report, files, out_dir)
            });
            if temporary {
                // Best effort: a folder left behind in the temporary area harms nothing.
                let _ = std::fs::remove_dir_all(&root);
            }
            result
        })
    }

    fn __repr__(&self) -> String {
        let analyses: Vec<String> = self.analyses().iter().map(|(k, n)| format!("{k} `{n}`")).collect();
        format!("<kanedyn.Study `{}`: {}>", self.study.spec.name, analyses.join(", "))
    }
}

/// A fresh, empty folder of this process in the system's temporary folder.
fn temporary_folder(py: Python<'_>) -> PyResult<PathBuf> {
    static COUNT: AtomicUsize = AtomicUsize::new(0);
    let base = std::env::temp_dir();
    let mut last = None;
    // `create_dir` fails on an existing path, so the folder is ours alone.
    for _ in 0..100 {
        let nanos = std::time::SystemTime::now().duration_since(std::time::UNIX_EPOCH).map_or(0, |d| d.subsec_nanos());
        let k = COUNT.fetch_add(1, Ordering::Relaxed);
        let dir = base.join(format!("kanedyn-study-{}-{k}-{nanos}", std::process::id()));
        match std::fs::create_dir(&dir) {
            Ok(()) => return Ok(dir),
            Err(e) => last = Some(e),
        }
    }
    let e = kanedyn::error::Error::Io {
        file: base,
        action: "cannot create a temporary folder in",
        source: last.unwrap_or_else(|| std::io::Error::other("no attempt")),
    };
    Err(to_py(py, &e))
}

/// A JSON value as Python objects: objects as dicts, arrays as lists, numbers as int or float,
/// null as None (json.load's mapping).
fn to_python<'py>(py: Python<'py>, v: &Value) -> PyResult<Bound<'py, PyAny>> {
    Ok(match v {
        Value::Null => py.None().into_bound(py),
        Value::Bool(b) => pyo3::types::PyBool::new(py, *b).to_owned().into_any(),
        Value::Number(n) => {
            if let Some(u) = n.as_u64() {
                u.into_pyobject(py)?.into_any()
            } else if let Some(i) = n.as_i64() {
                i.into_pyobject(py)?.into_any()
            } else {
                n.as_f64().unwrap_or(f64::NAN).into_pyobject(py)?.into_any()
            }
        }
        Value::String(s) => s.into_pyobject(py)?.into_any(),
        Value::Array(a) => {
            let list = PyList::empty(py);
            for x in a {
                list.append(to_python(py, x)?)?;
            }
            list.into_any()
        }
        Value::Object(o) => {
            let d = PyDict::new(py);
            for (k, x) in o {
                d.set_item(k, to_python(py, x)?)?;
            }
            d.into_any()
        }
    })
}

/// The results of a study run (``Study.run``).
#[pyclass(module = "kanedyn", frozen)]
pub struct StudyResult {
    /// ``"complete"``, or ``"partial"`` when anything failed (see ``failures``).
    #[pyo3(get)]
    status: String,
    /// Every failure, as the summary's Failures section lists it (analysis, place in the study
    /// file, reason); the other results are complete.
    #[pyo3(get)]
    failures: Vec<String>,
    /// The Markdown summary (``summary.md``).
    #[pyo3(get)]
    summary: String,
    /// The files written (empty when run without ``out``).
    #[pyo3(get)]
    files: Vec<String>,
    /// The output folder ``out/<study name>`` (None when run without ``out``).
    #[pyo3(get)]
    out_dir: Option<String>,
    /// The document ``results.json`` holds, as Python objects (dicts, lists, floats, None for
    /// JSON's null); its layout is ``docs/results.schema.json``.
    #[pyo3(get)]
    data: Py<PyDict>,
    /// Every CSV file's columns: ``tables[name][column]`` is a float64 array equal to the
    /// column of ``name.csv`` (NaN for an empty cell); e.g. ``tables["sweep_40Nm_up"]
    /// ["amp_1x_rad_s2"]``. ``pandas.DataFrame(tables[name])`` makes the file's table.
    #[pyo3(get)]
    tables: Py<PyDict>,
    /// The SI unit of every column: ``units[name][column]`` (``"1"``: dimensionless).
    #[pyo3(get)]
    units: Py<PyDict>,
    /// Every design study's case table: ``designs[name][column]`` is an array, ``case``, the
    /// parameter columns and the result columns float64 (NaN where none exists), ``status``
    /// (``ok``, ``partial``, ``failed``) and ``error`` (why) string arrays; the CSV file's
    /// columns. ``pandas.DataFrame(designs[name])`` makes the table.
    #[pyo3(get)]
    designs: Py<PyDict>,
    /// The document as JSON text, the content of ``results.json``.
    json: String,
}

impl StudyResult {
    fn new(
        py: Python<'_>,
        doc: &Document<'_>,
        report: &StudyReport,
        files: Vec<String>,
        out_dir: Option<String>,
    ) -> PyResult<Self> {
        let json_err =
            |e: serde_json::Error| pyo3::exceptions::PyRuntimeError::new_err(format!("results as JSON: {e}"));
        let json = serde_json::to_string(doc).map_err(json_err)?;
        let value: Value = serde_json::to_value(doc).map_err(json_err)?;
        let data = to_python(py, &value)?.cast_into::<PyDict>()?;
        let (tables, units) = (PyDict::new(py), PyDict::new(py));
        for a in &doc.analyses {
            // A comparison's tables are those of its mechanisms' analyses.
            for t in a.all_tables() {
                let (cols, us) = (PyDict::new(py), PyDict::new(py));
                for c in &t.columns {
                    cols.set_item(&c.name, PyArray1::from_slice(py, &c.values))?;
                    us.set_item(&c.name, c.unit)?;
                }
                tables.set_item(&t.name, cols)?;
                units.set_item(&t.name, us)?;
            }
        }
        Ok(Self {
            status: doc.status.to_string(),
            failures: doc.failures.to_vec(),
            summary: report.summary.clone(),
            files,
            out_dir,
            data: data.unbind(),
            tables: tables.unbind(),
            units: units.unbind(),
            designs: crate::design::tables(py, &report.designs)?.unbind(),
            json,
        })
    }
}

#[pymethods]
impl StudyResult {
    /// The results as JSON text: exactly what ``results.json`` holds.
    fn to_json(&self) -> &str {
        &self.json
    }

    /// One analysis's entry of ``data`` by name: ``kind``, ``status``, ``failures``,
    /// ``result`` (the library's results), ``findings`` (what the summary reads off them),
    /// ``tables``.
    fn analysis<'py>(&self, py: Python<'py>, name: &str) -> PyResult<Bound<'py, PyAny>> {
        let analyses = self.data.bind(py).get_item("analyses")?.ok_or_else(|| argument_error(py, "no analyses"))?;
        let mut names = Vec::new();
        for a in analyses.try_iter()? {
            let a = a?;
            let n: String = a.get_item("name")?.extract()?;
            if n == name {
                return Ok(a);
            }
            names.push(n);
        }
        Err(pyo3::exceptions::PyKeyError::new_err(format!("no analysis `{name}` (analyses: {})", names.join(", "))))
    }

    fn __repr__(&self, py: Python<'_>) -> String {
        format!(
            "<kanedyn.StudyResult {}: {} tables, {} failure(s)>",
            self.status,
            self.tables.bind(py).len(),
            self.failures.len()
        )
    }
}
