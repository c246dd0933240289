//! `kanedyn.simulate`: a time run of a mechanism with named probes, as NumPy arrays.
//!
//! The run is the library's own: [`kanedyn::time::probe::simulate`] with a [`Recorder`] of the
//! probes asked for, DOP853 with the options given, on the mechanism's [`Kane`] evaluator. A run
//! that ends early keeps the samples up to there and says why, as the library does; only bad
//! arguments raise.

use crate::arrays::{check_number, limit, vector};
use crate::errors::{argument_error, guard, message_of, to_py};
use crate::mechanism::Mechanism;
use kanedyn::kane::Kane;
use kanedyn::model::excitation::Excitation;
use kanedyn::study::validate::limits;
use kanedyn::time::integrate::{IntegrateError, IntegrateOptions};
use kanedyn::time::probe::{Outcome, Probe, ProbeKind, Recorder, simulate as run};
use numpy::{AllowTypeChange, PyArray1, PyArrayLikeDyn};
use pyo3::prelude::*;
use pyo3::types::PyDict;

/// Adds `simulate` and `Simulation` to the module.
pub fn register(m: &Bound<'_, PyModule>) -> PyResult<()> {
    m.add_function(wrap_pyfunction!(simulate, m)?)?;
    m.add_class::<Simulation>()
}

/// The probe kinds by name, in the order the docs list them.
const KINDS: [(&str, ProbeKind); 10] = [
    ("BodyAngle", ProbeKind::BodyAngle),
    ("BodyRate", ProbeKind::BodyRate),
    ("BodyAccel", ProbeKind::BodyAccel),
    ("JointAngle", ProbeKind::JointAngle),
    ("JointRate", ProbeKind::JointRate),
    ("LargestJointAngle", ProbeKind::LargestJointAngle),
    ("JointForceRadial", ProbeKind::JointForceRadial),
    ("JointForceTangential", ProbeKind::JointForceTangential),
    ("JointMoment", ProbeKind::JointMoment),
    ("GearMeshTorque", ProbeKind::GearMeshTorque),
];

/// Name of a probe kind.
fn kind_name(kind: ProbeKind) -> &'static str {
    KINDS.iter().find(|(_, k)| *k == kind).map_or("?", |(n, _)| n)
}

/// The probes `(kind, name)` resolved on `mech`.
fn read_probes(
    py: Python<'_>,
    mech: &kanedyn::model::mechanism::Mechanism,
    probes: &Bound<'_, PyAny>,
) -> PyResult<Vec<Probe>> {
    let kinds = || KINDS.iter().map(|(n, _)| *n).collect::<Vec<_>>().join(", ");
    let mut out = Vec::new();
    for (i, item) in probes.try_iter()?.enumerate() {
        let (kind, name): (String, String) = item?.extract().map_err(|e| {
            argument_error(
                py,
                format!("probes[{i}] must be a pair (kind, name) of strings, e.g. (\"BodyAccel\", \"rotor\") ({e})"),
            )
        })?;
        let Some(&(_, k)) = KINDS.iter().find(|(n, _)| *n == kind) else {
            return Err(argument_error(py, format!("probes[{i}]: unknown probe kind `{kind}` (kinds: {})", kinds())));
        };
        let probe = Probe::resolve(mech, k, &name)
            .map_err(|e| argument_error(py, format!("probes[{i}]: {}", message_of(&e))))?;
        out.push(probe);
    }
    Ok(out)
}

/// The initial state `[q; u]` from a 1-D array of 2n values or a pair `(q0, u0)` of n each.
fn read_state(py: Python<'_>, mech: &Mechanism, x0: &Bound<'_, PyAny>) -> PyResult<Vec<f64>> {
    let n = mech.mech.ndof();
    let names = mech.mech.joints.iter().filter(|j| j.coordinate.is_some()).map(|j| j.name.as_str());
    let expected = || {
        format!(
            "x0 must be [q; u] ({} values) or a pair (q0, u0) of {n} values each (coordinates: {})",
            2 * n,
            names.clone().collect::<Vec<_>>().join(", ")
        )
    };
    let array: PyArrayLikeDyn<'_, f64, AllowTypeChange> =
        x0.extract().map_err(|e| argument_error(py, format!("{} ({e})", expected())))?;
    let a = array.as_array();
    // A (2, n) array is the pair (q0, u0); its row-major order is [q; u].
    let fits = match a.shape() {
        [len] => *len == 2 * n,
        [2, len] => *len == n,
        _ => false,
    };
    if !fits {
        return Err(argument_error(py, format!("{}, got shape {:?}", expected(), a.shape())));
    }
    let x: Vec<f64> = a.iter().copied().collect();
    if let Some(i) = x.iter().position(|v| !v.is_finite()) {
        let (part, k) = if i < n { ("q", i) } else { ("u", i - n) };
        return Err(argument_error(py, format!("x0: {part}[{k}] is not finite ({})", x[i])));
    }
    Ok(x)
}

/// Integrates a mechanism's equations of motion from ``x0`` at ``t0`` to ``t1`` and records
/// named signals (probes) at a fixed sample rate.
///
/// The integrator is DOP853 (8th order, adaptive steps) with its dense output sampled at
/// ``t0 + k / sample_hz``; the loads are the mechanism's own (its joint torques may be replaced
/// by constants). This is the same run the library's ``time::probe::simulate`` makes, so a
/// study's time series equals it bit for bit.
///
/// Parameters
/// ----------
/// mechanism : Mechanism
/// x0 : array_like, shape (2n,) or (2, n)
///     Initial state ``[q; u]``, or the pair ``(q0, u0)``: coordinates (rad; m for a slide) in
///     coordinate order (``mechanism.coordinate_names``) and speeds in the mechanism's speed
///     definition (``mechanism.check()["speeds"]``).
/// t0, t1 : float
///     Start and end time, s (``t1 > t0``).
/// probes : sequence of (str, str)
///     What to record, as ``(kind, name)``: ``("BodyAngle", body)`` rad, ``("BodyRate", body)``
///     rad/s, ``("BodyAccel", body)`` rad/s² (absolute angle, angular velocity and angular
///     acceleration of a body); ``("JointAngle", joint)`` rad or m, ``("JointRate", joint)``
///     rad/s or m/s (a joint's coordinate and its rate); ``("LargestJointAngle", joint)`` rad,
///     the largest ``|q|`` over every coordinate except that joint's (a rotor's absorbers with
///     the spin joint excepted).
/// rtol, atol : float, default 1e-9
///     Relative and absolute tolerance of the local error per step.
/// sample_hz : float or None, default 2000.0
///     Sample rate, Hz; None records no samples (only the end state).
/// max_steps : int, default 100_000_000
///     Step attempts allowed; the run stops (and says so) when it is reached.
/// h0, h_max : float, optional
///     Initial and largest step, s (default: estimated, and unbounded).
/// joint_torques : dict of str to float, optional
///     Replaces the applied torque of each named joint by a constant, N·m, as in ``eom``.
///
/// Returns
/// -------
/// Simulation
///     ``time`` and one array per probe (``result["rotor.accel"]``, ``result[0]`` or
///     ``result["BodyAccel", "rotor"]``), with how the run ended: ``completed``, ``error``,
///     ``t_end``, ``x_end`` and the step counters.
///
/// Raises
/// ------
/// ArgumentError
///     A wrong ``x0``, probe, tolerance, time or joint name.
/// ModelError, EngineError
///     The mechanism cannot be evaluated.
///
/// Notes
/// -----
/// A run that fails on the way (a step-size underflow, a non-finite state, the step limit) does
/// not raise: the samples recorded up to there are kept and ``error`` says why. Continue a run
/// with ``simulate(m, r.x_end, r.t_end, t2, probes)``; its first sample repeats the last one.
///
/// Examples
/// --------
/// >>> m = kanedyn.Mechanism.from_file("examples/cpva.ron")
/// >>> r = kanedyn.simulate(m, [0, 0, 104.7, 104.7], 0.0, 10.0,
/// ...                      [("BodyAccel", "rotor"), ("JointAngle", "pivot")])
/// >>> r.time.shape, r["pivot.q"].max()
#[pyfunction]
#[pyo3(signature = (
    mechanism, x0, t0, t1, probes, *, rtol = 1e-9, atol = 1e-9, sample_hz = Some(2000.0),
    max_steps = 100_000_000, h0 = None, h_max = None, joint_torques = None
), text_signature = "(mechanism, x0, t0, t1, probes, *, rtol=1e-09, atol=1e-09, sample_hz=2000.0, max_steps=100000000, h0=None, h_max=None, joint_torques=None)")]
#[allow(clippy::too_many_arguments)]
fn simulate(
    py: Python<'_>,
    mechanism: PyRef<'_, Mechanism>,
    x0: Bound<'_, PyAny>,
    t0: f64,
    t1: f64,
    probes: Bound<'_, PyAny>,
    rtol: f64,
    atol: f64,
    sample_hz: Option<f64>,
    max_steps: usize,
    h0: Option<f64>,
    h_max: Option<f64>,
    joint_torques: Option<Bound<'_, PyAny>>,
) -> PyResult<Simulation> {
    guard(|| {
        let mech = &mechanism.mech;
        let x = read_state(py, &mechanism, &x0)?;
        let probes = read_probes(py, mech, &probes)?;
        check_number(py, "t0", t0, false)?;
        check_number(py, "t1", t1, false)?;
        if t1 <= t0 {
            return Err(argument_error(py, format!("t1 must be after t0, got t0 = {t0} s, t1 = {t1} s")));
        }
        check_number(py, "rtol", rtol, true)?;
        check_number(py, "atol", atol, true)?;
        for (name, v) in [("sample_hz", sample_hz), ("h0", h0), ("h_max", h_max)] {
            if let Some(v) = v {
                check_number(py, name, v, true)?;
            }
        }
        if max_steps == 0 {
            return Err(argument_error(py, "max_steps must be at least 1"));
        }
        // The command line's bounds: a day of simulated time at most, a tolerance the error
        // estimate can meet, and samples that fit the default memory limit (a sample rate of
        // 1e12 used to abort the interpreter on the failed allocation; t1 = 1e300 ran for minutes).
        limit(py, "t1", limits::check_run_time(t0, t1))?;
        limit(py, "rtol", limits::check_rtol(rtol))?;
        if let Some(hz) = sample_hz {
            limit(py, "sample_hz", limits::check_sample_hz(hz))?;
            limit(py, "sample_hz", limits::check_samples(t1 - t0, hz, probes.len() + 1))?;
        }
        let torques = match &joint_torques {
            Some(jt) => mechanism.read_torques(py, jt)?,
            None => Vec::new(),
        };
        let mut kane = Kane::new(mech).map_err(|e| to_py(py, &e))?;
        for &(joint, value) in &torques {
            kane.set_joint_torque(joint, Excitation::constant(value));
        }
        let mut rec = Recorder::new(mech, &probes).map_err(|e| to_py(py, &e))?;
        let opts = IntegrateOptions {
            rtol,
            atol,
            sample_rate_hz: sample_hz,
            sample_derivatives: false,
            max_steps,
            h0,
            h_max,
            deadline: None,
            method: kanedyn::time::integrate::Method::Dop853,
        };
        // The run holds no Python object: other threads may run meanwhile.
        let (outcome, rec) = py.detach(move || {
            let outcome = run(&mut kane, &x, t0, t1, &opts, &mut rec, &mut |_| {});
            (outcome, rec)
        });
        if let Some(IntegrateError::InvalidInput { message }) = &outcome.error {
            return Err(argument_error(py, message.clone()));
        }
        Simulation::new(py, mech, rec, outcome)
    })
}

/// The samples of a run: ``time`` and one array per probe, with how the run ended.
///
/// Index it by probe label (``"rotor.accel"``, ``"pivot.q"``: see ``names``), by position, or by
/// the ``(kind, name)`` pair it was asked with.
#[pyclass(module = "kanedyn", frozen)]
pub struct Simulation {
    /// Sample times, s.
    #[pyo3(get)]
    time: Py<PyArray1<f64>>,
    /// Probe labels, in the order asked: ``<body>.angle``, ``<body>.rate``, ``<body>.accel``,
    /// ``<joint>.q``, ``<joint>.qdot``, ``max_abs_q_except_<joint>``.
    #[pyo3(get)]
    names: Vec<String>,
    /// SI unit of each probe's values.
    #[pyo3(get)]
    units: Vec<String>,
    /// The probes as ``(kind, name)`` pairs.
    #[pyo3(get)]
    probes: Vec<(String, String)>,
    columns: Vec<Py<PyArray1<f64>>>,
    /// True when the run reached ``t1``.
    #[pyo3(get)]
    completed: bool,
    /// Why the run ended early (None when it completed); the samples up to there are kept.
    #[pyo3(get)]
    error: Option<String>,
    /// Time reached, s (``t1`` when completed).
    #[pyo3(get)]
    t_end: f64,
    /// State ``[q; u]`` at ``t1`` when completed, else None.
    #[pyo3(get)]
    x_end: Option<Py<PyArray1<f64>>>,
    /// Accepted steps.
    #[pyo3(get)]
    accepted: usize,
    /// Rejected steps.
    #[pyo3(get)]
    rejected: usize,
    /// Right-hand-side evaluations by the integrator.
    #[pyo3(get)]
    rhs_evals: usize,
    /// Right-hand-side evaluations at the samples (for accelerations).
    #[pyo3(get)]
    sample_rhs_evals: usize,
    /// Samples recorded.
    #[pyo3(get)]
    samples: usize,
    /// Wall-clock time of the run, s.
    #[pyo3(get)]
    wall_s: f64,
}

impl Simulation {
    fn new(
        py: Python<'_>,
        mech: &kanedyn::model::mechanism::Mechanism,
        rec: Recorder,
        outcome: Outcome,
    ) -> PyResult<Self> {
        let names = rec.names().to_vec();
        let units = rec.units().iter().map(|u| u.to_string()).collect();
        let probes = rec
            .probes()
            .iter()
            .map(|p| {
                let name = match p.kind() {
                    ProbeKind::BodyAngle | ProbeKind::BodyRate | ProbeKind::BodyAccel => &mech.bodies[p.index()].name,
                    _ => &mech.joints[p.index()].name,
                };
                (kind_name(p.kind()).to_string(), name.clone())
            })
            .collect();
        let s = outcome.stats;
        Ok(Self {
            time: PyArray1::from_vec(py, rec.time).unbind(),
            names,
            units,
            probes,
            columns: rec.columns.into_iter().map(|c| PyArray1::from_vec(py, c).unbind()).collect(),
            completed: outcome.error.is_none(),
            error: outcome.error.as_ref().map(|e| e.to_string()),
            t_end: outcome.t_end,
            x_end: outcome.x_end.as_deref().map(|x| vector(py, x).unbind()),
            accepted: s.accepted,
            rejected: s.rejected,
            rhs_evals: s.rhs_evals,
            sample_rhs_evals: s.sample_rhs_evals,
            samples: s.samples,
            wall_s: outcome.wall_s,
        })
    }

    /// The column for `key`: a position, a label or a `(kind, name)` pair.
    fn find(&self, py: Python<'_>, key: &Bound<'_, PyAny>) -> PyResult<usize> {
        let found = if let Ok(i) = key.extract::<isize>() {
            let n = self.columns.len() as isize;
            let k = if i < 0 { i + n } else { i };
            (0..n).contains(&k).then_some(k as usize)
        } else if let Ok(label) = key.extract::<String>() {
            self.names.iter().position(|n| *n == label)
        } else if let Ok(pair) = key.extract::<(String, String)>() {
            self.probes.iter().position(|p| *p == pair)
        } else {
            None
        };
        found.ok_or_else(|| {
            let key = key.repr().map_or_else(|_| "?".to_string(), |r| r.to_string());
            let _ = py;
            pyo3::exceptions::PyKeyError::new_err(format!("no probe {key} (probes: {})", self.names.join(", ")))
        })
    }
}

#[pymethods]
impl Simulation {
    /// The values of one probe: by label, position or ``(kind, name)``.
    fn __getitem__(&self, py: Python<'_>, key: Bound<'_, PyAny>) -> PyResult<Py<PyArray1<f64>>> {
        let i = self.find(py, &key)?;
        Ok(self.columns[i].clone_ref(py))
    }

    /// Number of probes.
    fn __len__(&self) -> usize {
        self.columns.len()
    }

    /// The probes' values by label, in the order asked (``pandas.DataFrame(r.columns,
    /// index=r.time)`` makes a table of them).
    #[getter]
    fn columns<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyDict>> {
        let d = PyDict::new(py);
        for (name, c) in self.names.iter().zip(&self.columns) {
            d.set_item(name, c.bind(py))?;
        }
        Ok(d)
    }

    fn __repr__(&self) -> String {
        let how = match &self.error {
            None => "completed".to_string(),
            Some(e) => format!("ended early: {e}"),
        };
        format!(
            "<kanedyn.Simulation: {} samples of {} to t = {} s, {how}>",
            self.samples,
            self.names.join(", "),
            self.t_end
        )
    }
}
