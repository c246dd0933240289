//! `kanedyn.linearize`: a mechanism linearised about a steady spin (the paper's eqs. 13 and 19),
//! its modes and its order-domain response (eq. 22), as NumPy arrays.
//!
//! Everything is the library's `kanedyn::linear`: [`LinearModel::new`] for the operating point
//! and the Jacobians, [`LinearModel::modes`] for the eigen-analysis and [`OrderResponse`] for the
//! response normalised by a locked twin, called as a study's `LinearResponse` calls them, so the
//! numbers equal the study's CSV columns.

use crate::arrays::{check_number, dmatrix, limit, matrix, read_finite, vector};
use crate::errors::{EngineError, argument_error, guard, message_of, model_error, to_py};
use crate::mechanism::Mechanism;
use kanedyn::linear::{
    Damping, LinearError, LinearModel, Mode, ModeKind, OrderResponse as Response, ResponseSpec, Spin,
};
use kanedyn::model::excitation::rpm_to_rad_s;
use kanedyn::model::mechanism::Mechanism as Mech;
use kanedyn::study::validate::limits;
use numpy::{Complex64, PyArray1, PyArray2, PyArrayMethods};
use pyo3::prelude::*;
use pyo3::types::{PyComplex, PyDict, PyList, PyTuple};

/// Adds `linearize` and its classes to the module.
pub fn register(m: &Bound<'_, PyModule>) -> PyResult<()> {
    m.add_function(wrap_pyfunction!(linearize, m)?)?;
    m.add_class::<Linearization>()?;
    m.add_class::<Modes>()?;
    m.add_class::<OrderResponse>()
}

/// The Python exception for a failure of the linear analysis: a bad name or argument is an
/// `ArgumentError`, a mechanism without a steady spin a `ModelError`, a numerical failure an
/// `EngineError`; the message is the library's.
pub fn linear_error(py: Python<'_>, mech: &Mech, e: &LinearError) -> PyErr {
    let message = message_of(e);
    match e {
        LinearError::Kanedyn(inner) => to_py(py, inner),
        LinearError::Unknown { .. }
        | LinearError::Length { .. }
        | LinearError::LockedInput { .. }
        | LinearError::Invalid(_) => argument_error(py, message),
        LinearError::SpinNotRoot { .. } | LinearError::SpinSpring { .. } | LinearError::WorldOrientation { .. } => {
            model_error(py, &mech.name, message)
        }
        LinearError::NoEquilibrium { .. }
        | LinearError::MassMatrix { .. }
        | LinearError::Eigen { .. }
        | LinearError::Watchdog { .. }
        | LinearError::Singular { .. } => EngineError::new_err(message),
    }
}

/// Linearises a mechanism about a steady spin of one root joint.
///
/// The spin joint turns at the constant speed ``rpm``; every other joint sits at its relative
/// equilibrium, found by Newton's method, held against the losses by a mean torque on the spin
/// joint (its applied torques are replaced by their means). The equations of motion are
/// linearised there (eq. 19 of the paper: ``M ẋ + A x = T``, ``x = [q*; u*]``).
///
/// Parameters
/// ----------
/// mechanism : Mechanism
///     Gravity and world-frame forces may act only on bodies that turn with the spin joint: the
///     model is linearised without them and they force it at order 1 (the library's
///     ``LinearModel::gravity_force``; not exposed here).
/// spin_joint : str
///     A revolute joint to ground without a spring.
/// rpm : float
///     Spin speed, rpm.
/// guess : array_like, shape (n,), optional
///     Starting coordinates of the equilibrium search, rad (the spin entry is ignored; default 0).
///
/// Returns
/// -------
/// LinearModel
///     The operating point, the linear matrices, ``modes(...)`` and ``order_response(...)``.
///
/// Raises
/// ------
/// ArgumentError
///     An unknown joint, a speed or guess that is not finite.
/// ModelError
///     Gravity, a world-frame force, a spin joint that is not a root or has a spring.
/// EngineError
///     No equilibrium found, or a mass matrix that is not positive definite there.
///
/// Examples
/// --------
/// >>> lin = kanedyn.linearize(kanedyn.Mechanism.from_file("examples/cpva.ron"), "spin", 1000.0)
/// >>> lin.modes(spin="held", damped=False).orders      # the tuning order n_t
#[pyfunction]
#[pyo3(signature = (mechanism, spin_joint, rpm, *, guess = None))]
fn linearize(
    py: Python<'_>,
    mechanism: PyRef<'_, Mechanism>,
    spin_joint: &str,
    rpm: f64,
    guess: Option<Bound<'_, PyAny>>,
) -> PyResult<Linearization> {
    guard(|| {
        let mech = mechanism.mech.clone();
        check_number(py, "rpm", rpm, false)?;
        // A standstill is a linearisation too (a Campbell diagram starts there); a negative speed
        // used to be accepted.
        limit(py, "rpm", limits::check_rpm(rpm, true))?;
        let guess = match &guess {
            Some(g) => Some(read_finite(py, "guess", g)?),
            None => None,
        };
        let omega = rpm_to_rad_s(rpm);
        let model = py
            .detach(|| LinearModel::new(&mech, spin_joint, omega, guess.as_deref()))
            .map_err(|e| linear_error(py, &mech, &e))?;
        Ok(Linearization { mech, model, rpm, guess })
    })
}

/// A mechanism linearised about a steady spin (``kanedyn.linearize``).
///
/// The state of the linear model is ``x = [q*; u*]`` (2n): the deviations of the coordinates
/// (spin angle included) and of the speeds from the steady spin.
#[pyclass(module = "kanedyn", frozen, name = "LinearModel")]
pub struct Linearization {
    /// The mechanism as given (the locked twin of `order_response` is built from it).
    mech: Mech,
    model: LinearModel,
    /// Spin speed, rpm.
    #[pyo3(get)]
    rpm: f64,
    guess: Option<Vec<f64>>,
}

/// `spin="free"|"held"` and `damped=True|False` as the library's switches.
fn switches(py: Python<'_>, spin: &str, damped: bool) -> PyResult<(Spin, Damping)> {
    let s = match spin {
        "free" => Spin::Free,
        "held" => Spin::Held,
        other => return Err(argument_error(py, format!("spin must be \"free\" or \"held\", not {other:?}"))),
    };
    Ok((s, if damped { Damping::Damped } else { Damping::Undamped }))
}

#[pymethods]
impl Linearization {
    /// The spin joint.
    #[getter]
    fn spin_joint(&self) -> &str {
        &self.mech.joints[self.model.op.spin_joint].name
    }

    /// Spin speed Ω, rad/s.
    #[getter]
    fn omega_rad_s(&self) -> f64 {
        self.model.op.omega
    }

    /// The joints owning the coordinates, in coordinate order (rows of the matrices).
    #[getter]
    fn coordinate_names(&self) -> Vec<String> {
        self.mech.joints.iter().filter(|j| j.coordinate.is_some()).map(|j| j.name.clone()).collect()
    }

    /// The steady spin, as a dict: ``spin_joint``; ``spin_coordinate`` (its index in q);
    /// ``omega_rad_s``; ``q`` (coordinates at t = 0: the spin angle 0, the others at their
    /// relative equilibrium, rad); ``u`` (speeds, rad/s); ``mean_spin_torque`` (N·m, holds the
    /// speed against the losses); ``residual`` (max ``|u̇|`` there, rad/s²); ``iterations``
    /// (Newton's).
    #[getter]
    fn operating_point<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyDict>> {
        let op = &self.model.op;
        let d = PyDict::new(py);
        d.set_item("spin_joint", self.spin_joint())?;
        d.set_item("spin_coordinate", op.spin_coordinate)?;
        d.set_item("omega_rad_s", op.omega)?;
        d.set_item("q", vector(py, &op.q))?;
        d.set_item("u", vector(py, &op.u))?;
        d.set_item("mean_spin_torque", op.mean_spin_torque)?;
        d.set_item("residual", op.residual)?;
        d.set_item("iterations", op.iterations)?;
        Ok(d)
    }

    /// Mass matrix M⁰ at the operating point, in the mechanism's speeds (kg·m² for rotations).
    #[getter]
    fn mass<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyArray2<f64>>> {
        dmatrix(py, &self.model.mass)
    }

    /// ∂F/∂q at the operating point (N·m/rad); the spin column is exactly 0 (cyclic angle).
    #[getter]
    fn f_q<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyArray2<f64>>> {
        dmatrix(py, &self.model.f_q)
    }

    /// ∂F/∂u at the operating point (N·m·s/rad), dampers included.
    #[getter]
    fn f_u<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyArray2<f64>>> {
        dmatrix(py, &self.model.f_u)
    }

    /// ∂F/∂u with every damper removed.
    #[getter]
    fn f_u_undamped<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyArray2<f64>>> {
        dmatrix(py, &self.model.f_u_undamped)
    }

    /// W⁻¹: ``q̇ = W⁻¹ u``.
    #[getter]
    fn w_inv<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyArray2<f64>>> {
        dmatrix(py, &self.model.w_inv)
    }

    /// The first-order form of eq. (19), ``M ẋ + A x = T``, ``x = [q*; u*]``.
    ///
    /// Returns
    /// -------
    /// M, A : ndarray, shape (2n, 2n)
    ///     ``M = diag(I, M⁰)``, ``A = [[0, −W⁻¹], [−F_q, −F_u]]`` (``F_u`` without dampers when
    ///     ``damped`` is False).
    #[pyo3(signature = (damped = true))]
    fn first_order<'py>(&self, py: Python<'py>, damped: bool) -> PyResult<Bound<'py, PyTuple>> {
        guard(|| {
            let f = self.model.first_order(if damped { Damping::Damped } else { Damping::Undamped });
            PyTuple::new(py, [dmatrix(py, &f.m)?, dmatrix(py, &f.a)?])
        })
    }

    /// The second-order form in the coordinates, ``M q̈* + C q̇* + K q* = τ``.
    ///
    /// Returns
    /// -------
    /// M, C, K : ndarray, shape (n, n)
    ///     ``Wᵀ M⁰ W`` (kg·m²), ``−Wᵀ F_u W`` (N·m·s/rad; dampers and gyroscopic coupling),
    ///     ``−Wᵀ F_q`` (N·m/rad).
    #[pyo3(signature = (damped = true))]
    fn second_order<'py>(&self, py: Python<'py>, damped: bool) -> PyResult<Bound<'py, PyTuple>> {
        guard(|| {
            let s = self.model.second_order(if damped { Damping::Damped } else { Damping::Undamped });
            PyTuple::new(py, [dmatrix(py, &s.m)?, dmatrix(py, &s.c)?, dmatrix(py, &s.k)?])
        })
    }

    /// The modes about the steady spin.
    ///
    /// Parameters
    /// ----------
    /// spin : {"free", "held"}, default "free"
    ///     ``"free"``: the spin speed is a degree of freedom (the rotor answers; for the CPVA the
    ///     rotor eigen-order n_r, eq. 17). ``"held"``: the spin speed is prescribed (for the CPVA
    ///     the pendulum's tuning order n_t, eq. 15).
    /// damped : bool, default True
    ///     Keep the dampers (else every damper is removed).
    ///
    /// Returns
    /// -------
    /// Modes
    ///     The n − 1 vibration modes by increasing natural frequency: ``orders``,
    ///     ``frequencies_hz``, ``damping_ratios``, ``labels``, ``shapes_q``, …; the rigid-body
    ///     modes of a free spin in ``rigid``.
    #[pyo3(signature = (spin = "free", damped = true))]
    fn modes(&self, py: Python<'_>, spin: &str, damped: bool) -> PyResult<Modes> {
        guard(|| {
            let (s, d) = switches(py, spin, damped)?;
            let modal = self.model.modes(s, d).map_err(|e| linear_error(py, &self.mech, &e))?;
            Modes::new(py, spin, damped, modal)
        })
    }

    /// The order-domain frequency response (eq. 22) to a unit torque in a joint, read as a
    /// body's angular acceleration, with the spin free.
    ///
    /// Parameters
    /// ----------
    /// input_joint : str
    ///     The joint carrying the torque ``e^{iΩnt}`` (1 N·m; e.g. the spin joint).
    /// body : str
    ///     The body whose angular acceleration is the response.
    /// orders : array_like
    ///     Excitation orders n (cycles per revolution).
    /// lock : sequence of str, default ()
    ///     Joints locked (at their operating-point angles) in a reference twin, as a study's
    ///     ``lock``; given, the twin's response and the ratio are returned too (the paper's
    ///     Fig. 2). The twin is linearised anew from the mechanism, as the study does.
    ///
    /// Returns
    /// -------
    /// OrderResponse
    ///     ``response`` (``|α̂|``, rad/s² per N·m), ``response_complex``; with ``lock``,
    ///     ``locked``, ``locked_complex``, ``ratio`` and ``asymptote``.
    ///
    /// Raises
    /// ------
    /// ArgumentError
    ///     An unknown joint or body, the input joint locked, an order that is not finite.
    /// EngineError
    ///     ``iΩnM + A`` singular at an order (an undamped resonance hit exactly).
    #[pyo3(signature = (input_joint, body, orders, lock = Vec::new()), text_signature = "(self, /, input_joint, body, orders, lock=())")]
    fn order_response(
        &self,
        py: Python<'_>,
        input_joint: &str,
        body: &str,
        orders: Bound<'_, PyAny>,
        lock: Vec<String>,
    ) -> PyResult<OrderResponse> {
        guard(|| {
            // Counted before the copy: 1e8 orders used to run for minutes.
            if let Ok(n) = orders.len() {
                limit(py, "orders", limits::check_point_count(n))?;
            }
            let orders = read_finite(py, "orders", &orders)?;
            limit(py, "orders", limits::check_point_count(orders.len()))?;
            for (i, &n) in orders.iter().enumerate() {
                limit(py, &format!("orders[{i}]"), limits::check_order(n))?;
            }
            let err = |e: LinearError| linear_error(py, &self.mech, &e);
            let spec = ResponseSpec {
                spin_joint: self.spin_joint().to_string(),
                inputs: vec![kanedyn::linear::Input::unit(input_joint)],
                body: body.to_string(),
                lock: lock.clone(),
            };
            let omega = self.model.op.omega;
            let (response, locked, asymptote) = if lock.is_empty() {
                let b = self.model.body_index(body).map_err(err)?;
                let j = self.model.joint_index(input_joint).map_err(err)?;
                let r: Vec<Complex64> = py
                    .detach(|| {
                        orders.iter().map(|&n| self.model.acceleration_response(b, j, n)).collect::<Result<_, _>>()
                    })
                    .map_err(err)?;
                (r, None, None)
            } else {
                let (mech, guess) = (&self.mech, self.guess.as_deref());
                let computed = py.detach(|| -> Result<_, LinearError> {
                    let resp = Response::new(mech, &spec, omega, guess)?;
                    let r = orders.iter().map(|&n| resp.response(n)).collect::<Result<Vec<_>, _>>()?;
                    let l = orders.iter().map(|&n| resp.locked_response(n)).collect::<Result<Vec<_>, _>>()?;
                    Ok((r, l, resp.asymptote()?))
                });
                let (r, l, a) = computed.map_err(err)?;
                (r, Some(l), Some(a))
            };
            let norm = |v: &[Complex64]| v.iter().map(|c| c.norm()).collect::<Vec<f64>>();
            let r_abs = norm(&response);
            let (l_abs, ratio) = match &locked {
                Some(l) => {
                    let l_abs = norm(l);
                    let ratio: Vec<f64> = r_abs.iter().zip(&l_abs).map(|(a, b)| a / b).collect();
                    (Some(l_abs), Some(ratio))
                }
                None => (None, None),
            };
            Ok(OrderResponse {
                orders: vector(py, &orders).unbind(),
                response: vector(py, &r_abs).unbind(),
                response_complex: PyArray1::from_vec(py, response).unbind(),
                locked: l_abs.map(|v| vector(py, &v).unbind()),
                locked_complex: locked.map(|v| PyArray1::from_vec(py, v).unbind()),
                ratio: ratio.map(|v| vector(py, &v).unbind()),
                asymptote,
                input_joint: input_joint.to_string(),
                body: body.to_string(),
                lock,
            })
        })
    }

    fn __repr__(&self) -> String {
        format!(
            "<kanedyn.LinearModel `{}` spinning on `{}` at {} rpm: {} degrees of freedom>",
            self.mech.name,
            self.spin_joint(),
            self.rpm,
            self.mech.ndof()
        )
    }
}

/// The modes of a linear model (``LinearModel.modes``): one entry per vibration mode, by
/// increasing natural frequency, in each array and list.
#[pyclass(module = "kanedyn", frozen)]
pub struct Modes {
    /// ``"free"`` or ``"held"``.
    #[pyo3(get)]
    spin: String,
    /// Whether the dampers are kept.
    #[pyo3(get)]
    damped: bool,
    /// Spin speed Ω, rad/s.
    #[pyo3(get)]
    omega_rad_s: f64,
    /// Joint names in coordinate order (the columns of the shapes).
    #[pyo3(get)]
    joints: Vec<String>,
    /// Body names (the columns of ``body_energy_shares``).
    #[pyo3(get)]
    bodies: Vec<String>,
    /// True when no eigenvalue has a positive real part.
    #[pyo3(get)]
    stable: bool,
    /// Eigen-orders ``|Im λ| / Ω`` (cycles per revolution; NaN at Ω = 0).
    #[pyo3(get)]
    orders: Py<PyArray1<f64>>,
    /// Damped natural frequencies ``|Im λ| / 2π``, Hz.
    #[pyo3(get)]
    frequencies_hz: Py<PyArray1<f64>>,
    /// Undamped natural frequencies ``ω_n``, rad/s.
    #[pyo3(get)]
    natural_frequencies_rad_s: Py<PyArray1<f64>>,
    /// Damping ratios (NaN for a zero-frequency mode).
    #[pyo3(get)]
    damping_ratios: Py<PyArray1<f64>>,
    /// Eigenvalues λ (Im λ ≥ 0), rad/s.
    #[pyo3(get)]
    eigenvalues: Py<PyArray1<Complex64>>,
    /// The joint that dominates each mode (largest coordinate share).
    #[pyo3(get)]
    labels: Vec<String>,
    /// Mode shapes in the coordinates q, one row per mode (largest ``q̇`` entry 1).
    #[pyo3(get)]
    shapes_q: Py<PyArray2<Complex64>>,
    /// Mode shapes in the joint rates ``q̇ = λ q``, one row per mode.
    #[pyo3(get)]
    shapes_qdot: Py<PyArray2<Complex64>>,
    /// Mode shapes in the mechanism's speeds u, one row per mode.
    #[pyo3(get)]
    shapes_u: Py<PyArray2<Complex64>>,
    /// Share of each coordinate in each mode's kinetic energy (rows sum to 1).
    #[pyo3(get)]
    coordinate_shares: Py<PyArray2<f64>>,
    /// Share of each body in each mode's kinetic energy (rows sum to 1).
    #[pyo3(get)]
    body_energy_shares: Py<PyArray2<f64>>,
    /// The rigid-body modes of a free spin (empty when held), each a dict with ``kind``
    /// (``"SpinAngle"`` or ``"SpinSpeed"``), ``eigenvalue`` (complex, rad/s), ``shape_q`` and
    /// ``shape_u``.
    #[pyo3(get)]
    rigid: Py<PyList>,
}

impl Modes {
    fn new(py: Python<'_>, spin: &str, damped: bool, modal: kanedyn::linear::Modal) -> PyResult<Self> {
        let modes = &modal.modes;
        let k = modes.len();
        let col = |f: &dyn Fn(&Mode) -> f64| vector(py, &modes.iter().map(f).collect::<Vec<f64>>()).unbind();
        let rows_c = |f: &dyn Fn(&Mode) -> &Vec<Complex64>, width: usize| -> PyResult<Py<PyArray2<Complex64>>> {
            Ok(matrix(py, k, width, modes.iter().flat_map(|m| f(m).iter().copied()).collect())?.unbind())
        };
        let rows_f = |f: &dyn Fn(&Mode) -> &Vec<f64>, width: usize| -> PyResult<Py<PyArray2<f64>>> {
            Ok(matrix(py, k, width, modes.iter().flat_map(|m| f(m).iter().copied()).collect())?.unbind())
        };
        let (n, nb) = (modal.joints.len(), modal.bodies.len());
        let rigid = PyList::empty(py);
        for m in &modal.rigid {
            let d = PyDict::new(py);
            d.set_item(
                "kind",
                match m.kind {
                    ModeKind::SpinAngle => "SpinAngle",
                    ModeKind::SpinSpeed => "SpinSpeed",
                    ModeKind::Vibration => "Vibration",
                },
            )?;
            d.set_item("eigenvalue", PyComplex::from_doubles(py, m.eigenvalue.re, m.eigenvalue.im))?;
            d.set_item("shape_q", PyArray1::from_slice(py, &m.shape_q))?;
            d.set_item("shape_u", PyArray1::from_slice(py, &m.shape_u))?;
            rigid.append(d)?;
        }
        Ok(Self {
            spin: spin.to_string(),
            damped,
            omega_rad_s: modal.omega,
            stable: modal.stable,
            orders: col(&|m| m.order),
            frequencies_hz: col(&|m| m.frequency_hz),
            natural_frequencies_rad_s: col(&|m| m.natural_frequency_rad_s),
            damping_ratios: col(&|m| m.damping_ratio),
            eigenvalues: PyArray1::from_vec(py, modes.iter().map(|m| m.eigenvalue).collect()).unbind(),
            labels: modes.iter().map(|m| m.label.clone()).collect(),
            shapes_q: rows_c(&|m| &m.shape_q, n)?,
            shapes_qdot: rows_c(&|m| &m.shape_qdot, n)?,
            shapes_u: rows_c(&|m| &m.shape_u, n)?,
            coordinate_shares: rows_f(&|m| &m.coordinate_share, n)?,
            body_energy_shares: rows_f(&|m| &m.body_energy_share, nb)?,
            rigid: rigid.unbind(),
            joints: modal.joints,
            bodies: modal.bodies,
        })
    }
}

#[pymethods]
impl Modes {
    /// Number of vibration modes.
    fn __len__(&self) -> usize {
        self.labels.len()
    }

    fn __repr__(&self, py: Python<'_>) -> String {
        let orders: Vec<String> =
            self.orders.bind(py).to_vec().unwrap_or_default().iter().map(|o| format!("{o:.6}")).collect();
        format!(
            "<kanedyn.Modes, spin {}, {}: orders {} ({})>",
            self.spin,
            if self.damped { "damped" } else { "undamped" },
            orders.join(", "),
            self.labels.join(", ")
        )
    }
}

/// The order-domain response of a linear model (``LinearModel.order_response``).
#[pyclass(module = "kanedyn", frozen)]
pub struct OrderResponse {
    /// Excitation orders n.
    #[pyo3(get)]
    orders: Py<PyArray1<f64>>,
    /// ``|α̂|`` of the body per unit torque, rad/s² per N·m.
    #[pyo3(get)]
    response: Py<PyArray1<f64>>,
    /// Complex ``α̂`` of the body per unit torque, rad/s² per N·m.
    #[pyo3(get)]
    response_complex: Py<PyArray1<Complex64>>,
    /// ``|α̂|`` of the locked twin's body, rad/s² per N·m (None without ``lock``).
    #[pyo3(get)]
    locked: Option<Py<PyArray1<f64>>>,
    /// Complex ``α̂`` of the locked twin's body (None without ``lock``).
    #[pyo3(get)]
    locked_complex: Option<Py<PyArray1<Complex64>>>,
    /// ``response / locked`` (the paper's Fig. 2; None without ``lock``).
    #[pyo3(get)]
    ratio: Option<Py<PyArray1<f64>>>,
    /// The ratio's high-order limit (inertia only), None without ``lock``.
    #[pyo3(get)]
    asymptote: Option<f64>,
    /// The joint carrying the torque.
    #[pyo3(get)]
    input_joint: String,
    /// The body watched.
    #[pyo3(get)]
    body: String,
    /// The joints locked in the twin.
    #[pyo3(get)]
    lock: Vec<String>,
}

#[pymethods]
impl OrderResponse {
    fn __len__(&self, py: Python<'_>) -> usize {
        self.orders.bind(py).len().unwrap_or(0)
    }

    fn __repr__(&self, py: Python<'_>) -> String {
        format!(
            "<kanedyn.OrderResponse of `{}` to a torque in `{}`: {} orders{}>",
            self.body,
            self.input_joint,
            self.__len__(py),
            if self.lock.is_empty() { String::new() } else { format!(", locked twin: {}", self.lock.join(", ")) }
        )
    }
}
