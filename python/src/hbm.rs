//! `kanedyn.hbm_branch`: a branch of periodic steady states by harmonic balance, continued in
//! the excitation order, with Floquet stability, folds and bifurcations, as NumPy arrays.
//!
//! The branch is the library's: [`RoutedHbm::new`] (the route a study takes: identical
//! absorbers by one scaled representative) and [`RoutedHbm::continue_in`] with the options a
//! study's `HarmonicBalance` uses, and the amplitudes read by
//! [`kanedyn::study::body_accel`], so the arrays equal the study's CSV columns.

use crate::arrays::{check_number, limit, matrix, vector};
use crate::errors::{EngineError, argument_error, guard, message_of, model_error, to_py};
use crate::mechanism::Mechanism;
use kanedyn::hbm::{
    BifurcationKind, BranchEnd, ContinuationOptions, FoldKind, HbmError, HbmOptions, Parameter, RoutedHbm,
};
use kanedyn::kane::Kane;
use kanedyn::model::excitation::{Harmonic, rpm_to_rad_s};
use kanedyn::study::body_accel;
use kanedyn::study::validate::limits;
use numpy::{PyArray1, PyArray2, PyArrayMethods};
use pyo3::prelude::*;
use pyo3::types::{PyDict, PyList};

/// Adds `hbm_branch` and `HbmBranch` to the module.
pub fn register(m: &Bound<'_, PyModule>) -> PyResult<()> {
    m.add_function(wrap_pyfunction!(hbm_branch, m)?)?;
    m.add_class::<HbmBranch>()
}

/// Continues the periodic steady state of a mechanism under a single-order torque in the
/// excitation order, by harmonic balance, with Floquet stability, folds and bifurcations.
///
/// The spin joint carries ``T(t) = T_m + amplitude · sin(n Ω t)`` at the mean speed ``rpm``; the
/// mean torque ``T_m`` is solved so that the mean speed stays Ω. Every coordinate is a truncated
/// Fourier series of ``harmonics`` harmonics of ``nΩ``; the branch is followed by
/// pseudo-arclength continuation from ``order_from`` towards ``order_to``, through folds (where
/// an order sweep jumps). The options are those of a study's ``HarmonicBalance``, so the arrays
/// equal its CSV columns.
///
/// Parameters
/// ----------
/// mechanism : Mechanism
///     Without gravity or world-frame forces, no oscillating torque on other joints.
/// spin_joint : str
///     A revolute joint to ground without a spring.
/// rpm : float
///     Mean speed, rpm (> 0).
/// amplitude : float
///     Torque amplitude T_n, N·m.
/// order_from, order_to : float
///     The order range (> 0), continued from ``order_from``.
/// harmonics : int, default 10
///     Harmonics H kept.
/// body : str, optional
///     The body whose angular-acceleration amplitudes are reported (default: the spin joint's
///     child, the rotor).
/// multiples : sequence of float, default (1.0, 2.0)
///     Multiples m of the excitation order reported (1: main order, 2: second order).
/// max_step : float, default 0.1
///     Largest arclength step (Fourier unknowns in rad and the order); lower it to resolve short
///     unstable stretches.
/// stability : bool, default True
///     Compute the Floquet stability of every point.
///
/// Returns
/// -------
/// HbmBranch
///     Per solved point: ``order``, ``accel`` (one row per multiple, rad/s²),
///     ``relative_angle`` (rad), ``stable``, ``max_multiplier``, ``mean_torque``; and the
///     ``folds``, ``bifurcations`` and how the continuation ``end``-ed.
///
/// Raises
/// ------
/// ArgumentError
///     An unknown joint or body, a number out of range.
/// ModelError
///     A mechanism whose spin angle is not cyclic, or with another oscillating torque.
/// EngineError
///     Newton's method failed at the start (no branch).
///
/// Examples
/// --------
/// >>> m = kanedyn.Mechanism.from_file("examples/cpva.ron")
/// >>> b = kanedyn.hbm_branch(m, "spin", 1000.0, 40.0, 3.3, 2.9)
/// >>> [f["order"] for f in b.folds]            # where the sweeps jump
#[pyfunction]
#[pyo3(signature = (
    mechanism, spin_joint, rpm, amplitude, order_from, order_to, harmonics = 10, *, body = None,
    multiples = vec![1.0, 2.0], max_step = 0.1, stability = true
), text_signature = "(mechanism, spin_joint, rpm, amplitude, order_from, order_to, harmonics=10, *, body=None, multiples=(1.0, 2.0), max_step=0.1, stability=True)")]
#[allow(clippy::too_many_arguments)]
fn hbm_branch(
    py: Python<'_>,
    mechanism: PyRef<'_, Mechanism>,
    spin_joint: &str,
    rpm: f64,
    amplitude: f64,
    order_from: f64,
    order_to: f64,
    harmonics: usize,
    body: Option<&str>,
    multiples: Vec<f64>,
    max_step: f64,
    stability: bool,
) -> PyResult<HbmBranch> {
    guard(|| {
        let mech = &mechanism.mech;
        let joint_names = || mech.joints.iter().map(|j| j.name.as_str()).collect::<Vec<_>>().join(", ");
        let spin = mech
            .joint_index(spin_joint)
            .ok_or_else(|| argument_error(py, format!("unknown joint `{spin_joint}` (joints: {})", joint_names())))?;
        // Body i hangs from joint i: the spin joint's child by default.
        let body_index = match body {
            Some(b) => mech.body_index(b).ok_or_else(|| {
                let names: Vec<&str> = mech.bodies.iter().map(|b| b.name.as_str()).collect();
                argument_error(py, format!("unknown body `{b}` (bodies: {})", names.join(", ")))
            })?,
            None => spin,
        };
        check_number(py, "rpm", rpm, true)?;
        check_number(py, "amplitude", amplitude, false)?;
        check_number(py, "order_from", order_from, true)?;
        check_number(py, "order_to", order_to, true)?;
        check_number(py, "max_step", max_step, true)?;
        if order_from == order_to {
            return Err(argument_error(py, format!("order_from and order_to must differ, both are {order_from}")));
        }
        if harmonics == 0 {
            return Err(argument_error(py, "harmonics must be at least 1"));
        }
        if let Some(m) = multiples.iter().find(|m| !(m.is_finite() && **m > 0.0)) {
            return Err(argument_error(py, format!("multiples must be finite and positive, got {m}")));
        }
        // The command line's bounds (`harmonics=10**9` used to abort the interpreter allocating
        // the Jacobian).
        limit(py, "rpm", limits::check_rpm(rpm, false))?;
        limit(py, "amplitude", limits::check_torque(amplitude))?;
        limit(py, "order_from", limits::check_order(order_from))?;
        limit(py, "order_to", limits::check_order(order_to))?;
        limit(py, "harmonics", limits::check_harmonics(harmonics))?;
        limit(py, "max_step", limits::check_max_step(max_step))?;
        if multiples.len() > 64 {
            return Err(argument_error(py, format!("multiples: give at most 64, got {}", multiples.len())));
        }
        for m in &multiples {
            limit(py, "multiples", limits::check_order(*m))?;
        }
        let kane = Kane::new(mech).map_err(|e| to_py(py, &e))?;
        let excitation = [Harmonic { multiple: 1.0, amplitude, phase: 0.0 }];
        let hbm_err = |e: HbmError| match e {
            HbmError::Invalid(_) => model_error(py, &mech.name, message_of(&e)),
            _ => EngineError::new_err(message_of(&e)),
        };
        let opts = HbmOptions { harmonics, ..HbmOptions::default() };
        let forcing = (&excitation[..], &[][..]);
        let mut hbm =
            RoutedHbm::new(&kane, spin, rpm_to_rad_s(rpm), forcing, &[(spin, 1.0, 0.0)], opts).map_err(hbm_err)?;
        // The study's continuation options (study::hbm::branch_in).
        let defaults = ContinuationOptions::default();
        let copts = ContinuationOptions { ds_max: max_step, ds: defaults.ds.min(max_step), stability, ..defaults };
        let start = std::time::Instant::now();
        let branch =
            py.detach(|| hbm.continue_in(Parameter::Order, order_from, order_to, None, &copts)).map_err(hbm_err)?;
        let wall_s = start.elapsed().as_secs_f64();
        let path = mech.rotation_rates(body_index);
        let p = &branch.points;
        let accel: Vec<f64> = multiples
            .iter()
            .flat_map(|&m| p.iter().map(|x| body_accel(&x.solution, &path, m)).collect::<Vec<_>>())
            .collect();
        let folds = PyList::empty(py);
        for f in &branch.folds {
            let d = PyDict::new(py);
            // The continued parameter is the order here (the study's fold column takes it).
            d.set_item("order", f.parameter)?;
            d.set_item("kind", if f.kind == FoldKind::Maximum { "Maximum" } else { "Minimum" })?;
            d.set_item("after", f.after)?;
            d.set_item("accel_main", f.accel_main)?;
            d.set_item("relative_angle", f.pendulum_amplitude)?;
            folds.append(d)?;
        }
        let bifurcations = PyList::empty(py);
        for b in &branch.bifurcations {
            let d = PyDict::new(py);
            d.set_item("order", b.parameter)?;
            d.set_item(
                "kind",
                match b.kind {
                    BifurcationKind::PlusOne => "PlusOne",
                    BifurcationKind::PeriodDoubling => "PeriodDoubling",
                    BifurcationKind::NeimarkSacker => "NeimarkSacker",
                },
            )?;
            d.set_item("classification", b.class.words())?;
            d.set_item("after", b.after)?;
            d.set_item("gains_stability", b.gains_stability)?;
            d.set_item("unstable_after", b.unstable_after)?;
            bifurcations.append(d)?;
        }
        let col =
            |f: &dyn Fn(&kanedyn::hbm::BranchPoint) -> f64| vector(py, &p.iter().map(f).collect::<Vec<f64>>()).unbind();
        Ok(HbmBranch {
            order: col(&|x| x.parameter),
            multiples: vector(py, &multiples).unbind(),
            accel: matrix(py, multiples.len(), p.len(), accel)?.unbind(),
            relative_angle: col(&|x| x.solution.max_peak_amplitude()),
            stable: col(&|x| x.stable.map_or(f64::NAN, |s| if s { 1.0 } else { 0.0 })),
            max_multiplier: col(&|x| x.solution.stability.as_ref().map_or(f64::NAN, |s| s.max_modulus)),
            mean_torque: col(&|x| x.solution.mean_torque),
            arclength: col(&|x| x.arclength),
            top_harmonic_ratio: col(&|x| x.solution.top_harmonic_ratio),
            folds: folds.unbind(),
            bifurcations: bifurcations.unbind(),
            end: match branch.end {
                BranchEnd::ReachedTarget => "ReachedTarget",
                BranchEnd::LeftRange => "LeftRange",
                BranchEnd::MaxPoints => "MaxPoints",
                BranchEnd::StepTooSmall => "StepTooSmall",
                BranchEnd::Watchdog => "Watchdog",
                BranchEnd::Unison => "Unison",
            }
            .to_string(),
            newton_iterations: branch.newton_iterations,
            wall_s,
            route: hbm.route().to_string(),
            rpm,
            amplitude,
            harmonics,
            body: mech.bodies[body_index].name.clone(),
        })
    })
}

/// A branch of periodic steady states (``kanedyn.hbm_branch``), its points in continuation
/// order.
#[pyclass(module = "kanedyn", frozen)]
pub struct HbmBranch {
    /// Excitation order n at each point.
    #[pyo3(get)]
    order: Py<PyArray1<f64>>,
    /// The multiples reported (rows of ``accel``).
    #[pyo3(get)]
    multiples: Py<PyArray1<f64>>,
    /// Angular-acceleration amplitude of ``body`` at order m·n, one row per multiple m, rad/s².
    #[pyo3(get)]
    accel: Py<PyArray2<f64>>,
    /// Largest peak ``|relative angle|`` of the joints other than the spin joint, rad.
    #[pyo3(get)]
    relative_angle: Py<PyArray1<f64>>,
    /// Floquet stability: 1.0 stable, 0.0 unstable, NaN not computed (the CSV's column).
    #[pyo3(get)]
    stable: Py<PyArray1<f64>>,
    /// Largest Floquet multiplier modulus (below 1: stable; NaN: not computed).
    #[pyo3(get)]
    max_multiplier: Py<PyArray1<f64>>,
    /// The mean spin torque T_m that holds the mean speed, N·m.
    #[pyo3(get)]
    mean_torque: Py<PyArray1<f64>>,
    /// Arclength along the branch (the continuation's norm).
    #[pyo3(get)]
    arclength: Py<PyArray1<f64>>,
    /// Share of the top harmonic in the acceleration spectrum (above 1e-5: raise ``harmonics``).
    #[pyo3(get)]
    top_harmonic_ratio: Py<PyArray1<f64>>,
    /// Turning points in the order, each a dict: ``order``, ``kind`` (``"Maximum"``: an
    /// up-sweep jumps here; ``"Minimum"``: a down-sweep), ``after`` (index of the point before
    /// it), ``accel_main`` (rad/s², the spin body's main order), ``relative_angle`` (rad).
    #[pyo3(get)]
    folds: Py<PyList>,
    /// Floquet multiplier crossings of the unit circle, each a dict: ``order``, ``kind``
    /// (``"PlusOne"``, ``"PeriodDoubling"``, ``"NeimarkSacker"``), ``classification`` (``"fold"``,
    /// ``"branch point"``, ``"period doubling"``, ``"Neimark–Sacker"``), ``after``,
    /// ``gains_stability``, ``unstable_after`` (multipliers outside the circle after it).
    #[pyo3(get)]
    bifurcations: Py<PyList>,
    /// How the continuation ended: ``"ReachedTarget"``, ``"LeftRange"``, ``"MaxPoints"``,
    /// ``"StepTooSmall"``, ``"Watchdog"`` or ``"Unison"`` (a switched branch back in unison).
    #[pyo3(get)]
    end: String,
    /// Newton iterations in total.
    #[pyo3(get)]
    newton_iterations: usize,
    /// Wall time of the continuation, s.
    #[pyo3(get)]
    wall_s: f64,
    /// How the branch was solved, in words: ``"cyclic (…)"`` (identical absorbers by one scaled
    /// representative, the sets named) or ``"general (…)"`` with the reason.
    #[pyo3(get)]
    route: String,
    /// Mean speed, rpm.
    #[pyo3(get)]
    rpm: f64,
    /// Torque amplitude T_n, N·m.
    #[pyo3(get)]
    amplitude: f64,
    /// Harmonics H kept.
    #[pyo3(get)]
    harmonics: usize,
    /// The body whose accelerations are reported.
    #[pyo3(get)]
    body: String,
}

#[pymethods]
impl HbmBranch {
    /// Number of points.
    fn __len__(&self, py: Python<'_>) -> usize {
        self.order.bind(py).to_vec().map_or(0, |v| v.len())
    }

    fn __repr__(&self, py: Python<'_>) -> String {
        format!(
            "<kanedyn.HbmBranch: {} points at {} N·m, {} rpm, {} fold(s), {}>",
            self.__len__(py),
            self.amplitude,
            self.rpm,
            self.folds.bind(py).len(),
            self.end
        )
    }
}
