//! Linear analysis of any mechanism about a steady spin: linearisation (paper §2.3, eq. 13),
//! the first-order form `M ẋ + A x = T` (eq. 19), eigen-orders and mode shapes, the order-domain
//! frequency response `x̂ = (iΩnM + A)⁻¹ â` (eq. 22) normalised by the locked mechanism (Fig. 2),
//! Campbell data and the linear multi-order response over speed (§4.2, Table 1).
//!
//! # The operating point
//! One root joint, the *spin joint* s, turns at the constant rate Ω (rad/s); every other joint j
//! sits at a relative equilibrium `q_j = q⁰_j`, `q̇_j = 0`, so `u⁰ = W q̇⁰` with `q̇⁰ = Ω e_s`
//! (with absolute angular velocities as speeds every body of the spinning subtree has u⁰ = Ω, as
//! in the paper's eqs. 9 and 11). The spin angle must be *cyclic*: F may not depend on it. That
//! holds when no load needs the world orientation (no gravity, no world-frame force) and the spin
//! joint has no spring; otherwise the steady spin is not an equilibrium of the equations (with
//! gravity the motion is periodic and the linear system time-periodic), and [`LinearModel::new`]
//! refuses with [`LinearError::WorldOrientation`] or [`LinearError::SpinSpring`].
//!
//! Steady spin against losses needs a mean torque T_m on the spin joint (for the CPVA `c_r Ω`).
//! Newton's method solves `F(q⁰, u⁰) + T_m g_s = 0` (all n rows, i.e. `u̇ = 0`) for the n − 1
//! other coordinates and T_m together, from a guess. Every applied joint torque of the mechanism
//! is replaced by its mean (its harmonics are the *input* of the frequency response, not part of
//! the operating point); the spin joint's own torque is replaced by the solved T_m.
//!
//! # Linearisation
//! With `q = q⁰ + Ω t e_s + q*`, `u = u⁰ + u*` and `u̇⁰ = 0`, the equations `q̇ = W⁻¹u`,
//! `M(q) u̇ = F(q, u) + g τ` give to first order
//!
//! `q̇* = W⁻¹ u*`, `M⁰ u̇* = F_q q* + F_u u* + g τ*`,
//!
//! i.e. eq. (19) with `x = [q*; u*]` (the spin angle's perturbation θ* included, as the paper's
//! `x = [θ, φ, u1, u2]`), `M = diag(I, M⁰)`, `A = [[0, −W⁻¹], [−F_q, −F_u]]`, `T = [0; g τ]`.
//! For the CPVA with the paper's speeds this is eq. (13) term by term: `F_q` holds `±m_p R L Ω²`
//! in the φ column, `F_u` the dampers. The derivatives are taken from the Kane engine
//! ([`forcing_jacobians`]): central differences extrapolated twice by Richardson (steps h, h/2,
//! h/4; error O(h⁶)). F is a quadratic polynomial in u, so its u-derivative by central
//! differences is exact up to rounding; in q it is built from sines and cosines, analytic, and the
//! O(h⁶) remainder at h = 0.05 rad is far below rounding (tests: ≤ 1e-12 relative to eq. 13).
//! `g` (the generalized force of a unit torque in joint k) is exact: `g_r = ∂q̇_k/∂u_r`, row k of
//! W⁻¹.
//!
//! The second-order form in the coordinates ([`LinearModel::second_order`]) substitutes
//! `u* = W q̇*` and projects on the joint rates (premultiplies by Wᵀ): `M_q q̈ + C q̇ + K q = τ`,
//! with `M_q = Wᵀ M⁰ W` symmetric whatever the speeds, `C = −Wᵀ F_u W` (dampers and any
//! gyroscopic coupling), `K = −Wᵀ F_q`; a joint torque enters its own row with a unit factor.
//!
//! # Spin free or held
//! With the spin *free* the mechanism answers the torque (the paper's eq. 13 both rows). The
//! spin angle is cyclic, so `θ*` appears in no equation: the state matrix has an exact zero
//! eigenvalue with shape `e_θ` (reported as [`ModeKind::SpinAngle`], computed analytically, not
//! numerically: undamped it forms a Jordan block with the next mode), and the remaining
//! eigenvalues come from the state without θ*. Among those, one real eigenvalue is the
//! spin-speed mode (the whole mechanism speeding up: 0 without losses, about `−c_r/J` with them),
//! [`ModeKind::SpinSpeed`]: the real eigenvalue of smallest modulus (there is always one: the
//! reduced state has odd dimension). With the spin *held* (speed prescribed, as for the paper's
//! eq. 14) the spin coordinate and its speed are removed (`θ* = 0`, `u_s* = 0`; the dropped row
//! is the reaction torque); the CPVA's pendulum then vibrates at n_t (eq. 15).

use crate::error::Error;
use crate::kane::Kane;
use crate::model::excitation::{Excitation, Harmonic, rpm_to_rad_s};
use crate::model::math::Vec2;
use crate::model::mechanism::Mechanism;
use crate::model::speeds::Speeds;
use nalgebra::{Complex, DMatrix, DVector};
use std::f64::consts::PI;

/// A complex number of f64 (nalgebra's re-export of `num_complex::Complex`).
pub type C64 = Complex<f64>;

/// First Richardson step for angle derivatives, rad. The error after two extrapolations is
/// O(h⁶) (≈ 1e-13 relative for sin/cos terms), rounding is ≈ ε·|F|/(h/4) ≈ 1e-14·|F|.
const H_ANGLE: f64 = 0.05;
/// First Richardson step for speed derivatives, relative to max(1, |u|): F is quadratic in u, so
/// any step is exact up to rounding; a large one keeps rounding small.
const H_SPEED_REL: f64 = 0.05;
/// Step of the plain central differences inside Newton's iteration, rad (Newton only needs a
/// good direction; the final Jacobians are the Richardson ones).
const H_NEWTON: f64 = 1e-6;
/// Newton iteration limit.
const NEWTON_MAX_ITER: usize = 50;
/// Accepted residual `max|u̇|` of the operating point, relative to `1 + Ω²` (rad/s²).
const NEWTON_ACCEPT: f64 = 1e-8;
/// Residual below which Newton stops, relative to `1 + Ω²`.
const NEWTON_TIGHT: f64 = 1e-13;
/// An eigenvalue counts as real when `|Im λ| ≤ REAL_TOL · scale` (scale: the largest |λ| or Ω).
const REAL_TOL: f64 = 1e-10;
/// Eigenvalues closer than `REPEAT_TOL · scale` share a null space (repeated roots, e.g. the
/// non-unison pendulum modes of N identical pendulums); they get distinct null vectors.
const REPEAT_TOL: f64 = 1e-7;
/// Samples per revolution of the base-order phase for the peak of a multi-order response.
const PEAK_SAMPLES: usize = 4096;

/// Failures of the linear analysis.
#[derive(Debug, thiserror::Error)]
pub enum LinearError {
    /// An error of the engine or of locking.
    #[error(transparent)]
    Kanedyn(#[from] Error),
    /// A name that the mechanism does not have.
    #[error("mechanism `{mechanism}`: unknown {what} `{name}` (known: {known})")]
    Unknown {
        /// Mechanism name.
        mechanism: String,
        /// "joint" or "body".
        what: &'static str,
        /// The name asked for.
        name: String,
        /// The names available.
        known: String,
    },
    /// The spin joint does not hang from ground.
    #[error("mechanism `{mechanism}`: spin joint `{joint}` must join a body to ground (it is the steady rotation)")]
    SpinNotRoot {
        /// Mechanism name.
        mechanism: String,
        /// Joint name.
        joint: String,
    },
    /// The spin joint has a spring to ground: a steady spin is not a relative equilibrium.
    #[error(
        "mechanism `{mechanism}`: spin joint `{joint}` has a spring ({stiffness} N·m/rad); a steady spin is not an equilibrium (model the shaft as a second joint behind a spinning hub)"
    )]
    SpinSpring {
        /// Mechanism name.
        mechanism: String,
        /// Joint name.
        joint: String,
        /// Its stiffness, N·m/rad.
        stiffness: f64,
    },
    /// Gravity or a world-frame force: the spin angle is not cyclic.
    #[error(
        "mechanism `{mechanism}`: gravity or a world-frame force makes the steady spin periodic, not an equilibrium; linear analysis about a spin needs a cyclic spin angle (turn gravity off or use body-frame forces)"
    )]
    WorldOrientation {
        /// Mechanism name.
        mechanism: String,
    },
    /// Newton's method found no relative equilibrium.
    #[error(
        "mechanism `{mechanism}`: no relative equilibrium at Ω = {omega} rad/s: residual max|u̇| = {residual:e} rad/s² after {iterations} Newton iterations (try another guess)"
    )]
    NoEquilibrium {
        /// Mechanism name.
        mechanism: String,
        /// Spin speed, rad/s.
        omega: f64,
        /// Final residual, rad/s².
        residual: f64,
        /// Iterations done.
        iterations: usize,
    },
    /// A vector argument of the wrong length.
    #[error("{what} has length {got}, the mechanism has {expected} coordinates")]
    Length {
        /// Which argument.
        what: &'static str,
        /// Its length.
        got: usize,
        /// The expected length.
        expected: usize,
    },
    /// The mass matrix at the operating point is not positive definite.
    #[error("mechanism `{mechanism}`: the mass matrix at the operating point is not positive definite")]
    MassMatrix {
        /// Mechanism name.
        mechanism: String,
    },
    /// The eigenvalue iteration did not converge.
    #[error("the eigenvalue solver did not converge on the {dim}×{dim} state matrix")]
    Eigen {
        /// State dimension.
        dim: usize,
    },
    /// `iΩnM + A` is singular: an undamped resonance hit exactly, or order 0.
    #[error("iΩnM + A is singular at order {order} (an undamped resonance hit exactly, or a zero frequency)")]
    Singular {
        /// The excitation order.
        order: f64,
    },
    /// The input joint is in the list of joints to lock.
    #[error("joint `{joint}` carries the input torque and cannot be locked")]
    LockedInput {
        /// Joint name.
        joint: String,
    },
    /// An argument out of its domain.
    #[error("invalid argument: {0}")]
    Invalid(String),
}

/// Result alias of this module.
pub type LinResult<T> = std::result::Result<T, LinearError>;

/// Whether the spin joint's speed is free (it answers torques) or held at Ω (prescribed).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Spin {
    /// The spin is a degree of freedom (the paper's eq. 13 both rows; the CPVA's n_r).
    Free,
    /// The spin speed is prescribed: θ* = 0, u_s* = 0 (the paper's eq. 14; the CPVA's n_t).
    Held,
}

/// Whether the dampers of the mechanism are kept.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Damping {
    /// Joint dampers and dampers to ground included.
    Damped,
    /// Every damper removed from `F_u` (C = 0 apart from gyroscopic coupling); same operating point.
    Undamped,
}

/// The steady spin about which the mechanism is linearised.
#[derive(Debug, Clone, PartialEq)]
pub struct OperatingPoint {
    /// Index of the spin joint (= its coordinate).
    pub spin_joint: usize,
    /// Spin speed Ω, rad/s.
    pub omega: f64,
    /// Coordinates at t = 0 (the spin angle is 0; the others at their relative equilibrium), rad.
    pub q: Vec<f64>,
    /// Speeds u⁰ = W Ω e_s, rad/s.
    pub u: Vec<f64>,
    /// Mean torque on the spin joint that holds the speed against the losses, N·m.
    pub mean_spin_torque: f64,
    /// Residual `max|u̇|` at the solution, rad/s².
    pub residual: f64,
    /// Newton iterations used.
    pub iterations: usize,
}

/// The first-order form of eq. (19), `M ẋ + A x = T`, `x = [q*; u*]` (2n).
#[derive(Debug, Clone, PartialEq)]
pub struct FirstOrder {
    /// `diag(I, M⁰)`.
    pub m: DMatrix<f64>,
    /// `[[0, −W⁻¹], [−F_q, −F_u]]`.
    pub a: DMatrix<f64>,
}

/// The second-order form in the coordinates: `M q̈* + C q̇* + K q* = τ` (n), the equations
/// projected on the joint rates (see the module docs).
#[derive(Debug, Clone, PartialEq)]
pub struct SecondOrder {
    /// `Wᵀ M⁰ W`, kg·m², symmetric.
    pub m: DMatrix<f64>,
    /// `−Wᵀ F_u W`, N·m·s/rad.
    pub c: DMatrix<f64>,
    /// `−Wᵀ F_q`, N·m/rad.
    pub k: DMatrix<f64>,
}

/// What a mode is.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum ModeKind {
    /// Rigid rotation of the whole spinning mechanism by a constant angle (λ = 0 exactly).
    SpinAngle,
    /// Rigid change of spin speed (λ = 0 without losses, ≈ −c_r/J with them).
    SpinSpeed,
    /// A vibration mode (one per remaining degree of freedom; zero-frequency ones included, e.g. a
    /// pendulum at Ω = 0).
    Vibration,
}

/// One mode of the linearised mechanism.
#[derive(Debug, Clone, PartialEq)]
pub struct Mode {
    /// What it is.
    pub kind: ModeKind,
    /// Its eigenvalue λ (rad/s), with Im λ ≥ 0; for a pair of real eigenvalues (an overdamped
    /// or zero-frequency mode) the one of smaller modulus.
    pub eigenvalue: C64,
    /// The other eigenvalue of the mode: the conjugate, or the other real one.
    pub partner: C64,
    /// Undamped natural frequency ω_n = |λ| (= sqrt(λ₁λ₂) for a real pair), rad/s.
    pub natural_frequency_rad_s: f64,
    /// Damped frequency |Im λ|, rad/s.
    pub damped_frequency_rad_s: f64,
    /// Damped frequency in Hz.
    pub frequency_hz: f64,
    /// Eigen-order |Im λ| / Ω (NaN at Ω = 0).
    pub order: f64,
    /// Damping ratio −Re λ / |λ| (−(λ₁+λ₂)/(2ω_n) for a real pair; NaN when ω_n = 0).
    pub damping_ratio: f64,
    /// Shape in the coordinates q (n entries, joint order), scaled so that the largest entry of
    /// `shape_qdot` is 1 (for a zero-frequency vibration mode, where q̇ = λq vanishes, the
    /// largest entry of `shape_q` is 1 instead). For the spin-speed mode the spin angle entry is
    /// left at 0 (it grows linearly in time there).
    pub shape_q: Vec<C64>,
    /// Shape in the joint rates q̇ = W⁻¹u (= λ·shape_q), largest entry 1.
    pub shape_qdot: Vec<C64>,
    /// Shape in the speeds u of the mechanism, same scaling.
    pub shape_u: Vec<C64>,
    /// Share of each coordinate, `|q̇_j|² (M_q)_jj` normalised to sum 1 (the diagonal part of
    /// the kinetic energy; independent of the speeds choice; `|q_j|²` in place of `|q̇_j|²` for
    /// a zero-frequency mode).
    pub coordinate_share: Vec<f64>,
    /// Share of each body in the mode's kinetic energy `½(m|v|² + I|ω|²)` (sum 1; all 0 for the
    /// spin-angle mode, which has no velocity).
    pub body_energy_share: Vec<f64>,
    /// Name of the joint with the largest coordinate share.
    pub label: String,
}

/// The eigen-analysis of a linear model.
#[derive(Debug, Clone, PartialEq)]
pub struct Modal {
    /// Spin speed Ω, rad/s.
    pub omega: f64,
    /// Spin free or held.
    pub spin: Spin,
    /// Dampers kept or removed.
    pub damping: Damping,
    /// Joint names (coordinate order).
    pub joints: Vec<String>,
    /// Body names.
    pub bodies: Vec<String>,
    /// Rigid-body modes of the free spin (spin angle, spin speed); empty when held.
    pub rigid: Vec<Mode>,
    /// Vibration modes (n − 1 of them), by increasing natural frequency.
    pub modes: Vec<Mode>,
    /// True when no eigenvalue has a positive real part (beyond rounding).
    pub stable: bool,
}

/// A mechanism linearised about a steady spin. See the module docs.
#[derive(Debug, Clone)]
pub struct LinearModel {
    mech: Mechanism,
    /// The operating point.
    pub op: OperatingPoint,
    /// M⁰ = M(q⁰) in the mechanism's speeds, kg·m².
    pub mass: DMatrix<f64>,
    /// ∂F/∂q at the operating point, N·m/rad (the spin column is exactly 0).
    pub f_q: DMatrix<f64>,
    /// ∂F/∂u at the operating point, N·m·s/rad.
    pub f_u: DMatrix<f64>,
    /// ∂F/∂u with every damper removed.
    pub f_u_undamped: DMatrix<f64>,
    /// W⁻¹ (q̇ = W⁻¹u).
    pub w_inv: DMatrix<f64>,
    partials: Vec<(Vec<Vec2>, Vec<f64>)>,
}

/// The Jacobians `(∂F/∂q, ∂F/∂u)` of the engine's forcing at `(q, u)`, t = 0, by central
/// differences with two Richardson extrapolations (steps h, h/2, h/4, error O(h⁶)): h = 0.05 rad
/// for the angles, h = 0.05·max(1, |u|) for the speeds (F is quadratic in u, so the central
/// difference is exact there up to rounding). Time-dependent torques are frozen at t = 0.
pub fn forcing_jacobians(kane: &mut Kane, q: &[f64], u: &[f64]) -> (DMatrix<f64>, DMatrix<f64>) {
    let h_u = H_SPEED_REL * u.iter().fold(1.0f64, |a, &b| a.max(b.abs()));
    let f_q = richardson_jacobian(q, H_ANGLE, |x| kane.forcing(0.0, x, u).clone());
    let f_u = richardson_jacobian(u, h_u, |x| kane.forcing(0.0, q, x).clone());
    (f_q, f_u)
}

/// Central differences at h, h/2, h/4 combined as `R2 = (16 R1(h/2) − R1(h))/15` with
/// `R1(h) = (4 D(h/2) − D(h))/3`: the h² and h⁴ error terms cancel.
fn richardson_jacobian(x0: &[f64], h: f64, mut f: impl FnMut(&[f64]) -> DVector<f64>) -> DMatrix<f64> {
    let mut x = x0.to_vec();
    let mut cols = Vec::with_capacity(x0.len());
    for j in 0..x0.len() {
        let mut d: Vec<DVector<f64>> = Vec::with_capacity(3);
        for level in 0..3 {
            let hl = h / f64::from(1u32 << level);
            x[j] = x0[j] + hl;
            let xp = x[j];
            let fp = f(&x);
            x[j] = x0[j] - hl;
            let xm = x[j];
            let fm = f(&x);
            x[j] = x0[j];
            // Divide by the steps actually taken (x0 ± h rounds).
            d.push((fp - fm) / (xp - xm));
        }
        let r1a = (&d[1] * 4.0 - &d[0]) / 3.0;
        let r1b = (&d[2] * 4.0 - &d[1]) / 3.0;
        cols.push((r1b * 16.0 - r1a) / 15.0);
    }
    let rows = cols.first().map_or(0, |c| c.len());
    let mut jac = DMatrix::zeros(rows, x0.len());
    for (j, c) in cols.iter().enumerate() {
        jac.set_column(j, c);
    }
    jac
}

fn unknown(mech: &Mechanism, what: &'static str, name: &str) -> LinearError {
    let known: Vec<&str> = if what == "joint" {
        mech.joints.iter().map(|j| j.name.as_str()).collect()
    } else {
        mech.bodies.iter().map(|b| b.name.as_str()).collect()
    };
    LinearError::Unknown { mechanism: mech.name.clone(), what, name: name.into(), known: known.join(", ") }
}

fn joint_of(mech: &Mechanism, name: &str) -> LinResult<usize> {
    mech.joint_index(name).ok_or_else(|| unknown(mech, "joint", name))
}

fn body_of(mech: &Mechanism, name: &str) -> LinResult<usize> {
    mech.body_index(name).ok_or_else(|| unknown(mech, "body", name))
}

/// The mechanism at its operating point's loads: applied torques frozen at their means, the spin
/// joint's torque removed (T_m is solved for).
fn prepare(mech: &Mechanism, spin: usize) -> Mechanism {
    let mut m = mech.clone();
    m.loads.joint_torques.retain(|t| t.joint != spin);
    for t in &mut m.loads.joint_torques {
        t.excitation = Excitation::constant(t.excitation.mean);
    }
    m
}

/// The same mechanism without dampers.
fn undamped(mech: &Mechanism) -> Mechanism {
    let mut m = mech.clone();
    for j in &mut m.joints {
        j.damper = 0.0;
    }
    m.loads.ground_dampers.clear();
    m
}

/// W⁻¹ column by column: column r is q̇ for u = e_r (exact: entries 0, ±1).
fn w_inverse(mech: &Mechanism) -> DMatrix<f64> {
    let n = mech.ndof();
    let parents = mech.parents();
    let mut w = DMatrix::zeros(n, n);
    let mut e = vec![0.0; n];
    let mut col = vec![0.0; n];
    for r in 0..n {
        e.iter_mut().for_each(|x| *x = 0.0);
        e[r] = 1.0;
        mech.speeds.qdot(&parents, &e, &mut col);
        for k in 0..n {
            w[(k, r)] = col[k];
        }
    }
    w
}

fn select(m: &DMatrix<f64>, rows: &[usize], cols: &[usize]) -> DMatrix<f64> {
    DMatrix::from_fn(rows.len(), cols.len(), |i, j| m[(rows[i], cols[j])])
}

impl LinearModel {
    /// Linearises `mech` about a steady spin of joint `spin_joint` at `omega_rad_s`, the other
    /// coordinates at the relative equilibrium found by Newton from `guess` (all n coordinates;
    /// the spin entry is ignored; default all 0).
    pub fn new(mech: &Mechanism, spin_joint: &str, omega_rad_s: f64, guess: Option<&[f64]>) -> LinResult<Self> {
        let n = mech.ndof();
        let s = joint_of(mech, spin_joint)?;
        if mech.joints[s].parent.is_some() {
            return Err(LinearError::SpinNotRoot { mechanism: mech.name.clone(), joint: spin_joint.into() });
        }
        if let Some(sp) = mech.joints[s].spring
            && sp.stiffness != 0.0
        {
            return Err(LinearError::SpinSpring {
                mechanism: mech.name.clone(),
                joint: spin_joint.into(),
                stiffness: sp.stiffness,
            });
        }
        if mech.loads.needs_world_orientation() {
            return Err(LinearError::WorldOrientation { mechanism: mech.name.clone() });
        }
        if !omega_rad_s.is_finite() {
            return Err(LinearError::Invalid(format!("spin speed must be finite, got {omega_rad_s} rad/s")));
        }
        let mut q = match guess {
            Some(g) if g.len() != n => return Err(LinearError::Length { what: "guess", got: g.len(), expected: n }),
            Some(g) => g.to_vec(),
            None => vec![0.0; n],
        };
        q[s] = 0.0;
        let prepared = prepare(mech, s);
        let mut kane = Kane::new(&prepared)?;
        let w_inv = w_inverse(&prepared);
        let parents = prepared.parents();
        let mut qdot0 = vec![0.0; n];
        qdot0[s] = omega_rad_s;
        let mut u = vec![0.0; n];
        prepared.speeds.u_from_qdot(&parents, &qdot0, &mut u);
        let g_s: DVector<f64> = w_inv.row(s).transpose();

        // Newton on z = [q_j (j ≠ s); T_m] for r(z) = F(q, u⁰) + T_m g_s = 0.
        let others: Vec<usize> = (0..n).filter(|&j| j != s).collect();
        let scale = 1.0 + omega_rad_s * omega_rad_s;
        let mut t_m = 0.0;
        let mut iterations = 0;
        let accel = |kane: &mut Kane, q: &[f64], t_m: f64| -> LinResult<(DVector<f64>, f64)> {
            let r = kane.forcing(0.0, q, &u).clone() + &g_s * t_m;
            let chol = kane
                .mass_matrix(q)
                .clone()
                .cholesky()
                .ok_or_else(|| LinearError::MassMatrix { mechanism: mech.name.clone() })?;
            let udot = chol.solve(&r);
            Ok((r, udot.amax()))
        };
        let (mut r, mut residual) = accel(&mut kane, &q, t_m)?;
        while residual > NEWTON_TIGHT * scale && iterations < NEWTON_MAX_ITER {
            let mut jac = DMatrix::zeros(n, n);
            for (c, &j) in others.iter().enumerate() {
                let q0 = q[j];
                q[j] = q0 + H_NEWTON;
                let fp = kane.forcing(0.0, &q, &u).clone();
                q[j] = q0 - H_NEWTON;
                let fm = kane.forcing(0.0, &q, &u).clone();
                q[j] = q0;
                jac.set_column(c, &((fp - fm) / (2.0 * H_NEWTON)));
            }
            jac.set_column(n - 1, &g_s);
            // The pseudo-inverse takes the minimum-norm step along neutral directions (a
            // pendulum at Ω = 0, a second free root) instead of failing.
            let svd = jac.svd(true, true);
            let eps = 1e-13 * svd.singular_values.max();
            let step = svd.solve(&(-&r), eps).map_err(|e| LinearError::Invalid(format!("internal: {e}")))?;
            for (c, &j) in others.iter().enumerate() {
                q[j] += step[c];
            }
            t_m += step[n - 1];
            iterations += 1;
            let small = others.iter().enumerate().all(|(c, _)| step[c].abs() <= 1e-15)
                && step[n - 1].abs() <= 1e-15 * (1.0 + t_m.abs());
            (r, residual) = accel(&mut kane, &q, t_m)?;
            if small {
                break;
            }
        }
        // NaN must fail too.
        if residual.is_nan() || residual > NEWTON_ACCEPT * scale {
            return Err(LinearError::NoEquilibrium {
                mechanism: mech.name.clone(),
                omega: omega_rad_s,
                residual,
                iterations,
            });
        }
        kane.set_joint_torque(s, Excitation::constant(t_m));
        let mass = kane.mass_matrix(&q).clone();
        let (f_q, f_u) = forcing_jacobians(&mut kane, &q, &u);
        let mut kane_free = Kane::new(&undamped(&prepared))?;
        let (_, f_u_undamped) = forcing_jacobians(&mut kane_free, &q, &u);
        let partials = (0..n).map(|j| kane.partial_velocities(&q, j)).collect();
        let mut model_mech = prepared;
        model_mech
            .loads
            .joint_torques
            .push(crate::model::loads::JointTorque { joint: s, excitation: Excitation::constant(t_m) });
        Ok(LinearModel {
            mech: model_mech,
            op: OperatingPoint { spin_joint: s, omega: omega_rad_s, q, u, mean_spin_torque: t_m, residual, iterations },
            mass,
            f_q,
            f_u,
            f_u_undamped,
            w_inv,
            partials,
        })
    }

    /// The mechanism as linearised: applied torques frozen at their means, the spin joint driven
    /// by the mean torque T_m.
    pub fn mechanism(&self) -> &Mechanism {
        &self.mech
    }

    /// Number of degrees of freedom n.
    pub fn ndof(&self) -> usize {
        self.mech.ndof()
    }

    /// Index of a joint by name.
    pub fn joint_index(&self, name: &str) -> LinResult<usize> {
        joint_of(&self.mech, name)
    }

    /// Index of a body by name.
    pub fn body_index(&self, name: &str) -> LinResult<usize> {
        body_of(&self.mech, name)
    }

    fn f_u_of(&self, damping: Damping) -> &DMatrix<f64> {
        match damping {
            Damping::Damped => &self.f_u,
            Damping::Undamped => &self.f_u_undamped,
        }
    }

    /// Generalized force (n entries) of a unit torque in joint `joint` (+1 N·m on the child, −1 on
    /// the parent): `g_r = ∂q̇_joint/∂u_r`.
    pub fn generalized_torque(&self, joint: usize) -> DVector<f64> {
        self.w_inv.row(joint).transpose()
    }

    /// The row c of the absolute angular velocity of body `body`, `ω_body = c·u` (the sum of the
    /// joint rates on its path).
    pub fn angular_velocity_row(&self, body: usize) -> DVector<f64> {
        let mut c = DVector::zeros(self.ndof());
        for k in self.mech.path_to(body) {
            c += self.w_inv.row(k).transpose();
        }
        c
    }

    /// Eq. (19): `M ẋ + A x = T` with `x = [q*; u*]`, 2n states, the spin angle included.
    pub fn first_order(&self, damping: Damping) -> FirstOrder {
        let n = self.ndof();
        let mut m = DMatrix::identity(2 * n, 2 * n);
        m.view_mut((n, n), (n, n)).copy_from(&self.mass);
        let mut a = DMatrix::zeros(2 * n, 2 * n);
        a.view_mut((0, n), (n, n)).copy_from(&(-&self.w_inv));
        a.view_mut((n, 0), (n, n)).copy_from(&(-&self.f_q));
        a.view_mut((n, n), (n, n)).copy_from(&(-self.f_u_of(damping)));
        FirstOrder { m, a }
    }

    /// The right-hand side â of eq. (19) (2n entries) for a unit torque in joint `joint`.
    pub fn input(&self, joint: &str) -> LinResult<DVector<f64>> {
        let k = self.joint_index(joint)?;
        let n = self.ndof();
        let mut a = DVector::zeros(2 * n);
        a.rows_mut(n, n).copy_from(&self.generalized_torque(k));
        Ok(a)
    }

    /// The second-order form in the coordinates (see the module docs).
    pub fn second_order(&self, damping: Damping) -> SecondOrder {
        let w = self.w_inv.clone().try_inverse().unwrap_or_else(|| DMatrix::identity(self.ndof(), self.ndof()));
        let wt = w.transpose();
        SecondOrder { m: &wt * &self.mass * &w, c: -(&wt * self.f_u_of(damping) * &w), k: -(&wt * &self.f_q) }
    }

    /// Kept coordinate and speed indices of the reduced state (the spin angle is always dropped:
    /// cyclic).
    fn kept(&self, spin: Spin) -> (Vec<usize>, Vec<usize>) {
        let s = self.op.spin_joint;
        let qi: Vec<usize> = (0..self.ndof()).filter(|&j| j != s).collect();
        let ui = match spin {
            Spin::Free => (0..self.ndof()).collect(),
            Spin::Held => qi.clone(),
        };
        (qi, ui)
    }

    /// The reduced state matrix `ẋ_r = S x_r`, `x_r = [q_qi; u_ui]`.
    fn state_matrix(&self, spin: Spin, damping: Damping) -> LinResult<(DMatrix<f64>, Vec<usize>, Vec<usize>)> {
        let (qi, ui) = self.kept(spin);
        let (nq, nu) = (qi.len(), ui.len());
        let chol = select(&self.mass, &ui, &ui)
            .cholesky()
            .ok_or_else(|| LinearError::MassMatrix { mechanism: self.mech.name.clone() })?;
        let mut s = DMatrix::zeros(nq + nu, nq + nu);
        s.view_mut((0, nq), (nq, nu)).copy_from(&select(&self.w_inv, &qi, &ui));
        s.view_mut((nq, 0), (nu, nq)).copy_from(&chol.solve(&select(&self.f_q, &ui, &qi)));
        s.view_mut((nq, nq), (nu, nu)).copy_from(&chol.solve(&select(self.f_u_of(damping), &ui, &ui)));
        Ok((s, qi, ui))
    }

    /// Eigen-analysis: rigid-body modes of the free spin and the n − 1 vibration modes with
    /// eigen-orders, damping ratios, shapes and participation (see [`Mode`]).
    pub fn modes(&self, spin: Spin, damping: Damping) -> LinResult<Modal> {
        let n = self.ndof();
        let s = self.op.spin_joint;
        let omega = self.op.omega;
        let (sm, qi, ui) = self.state_matrix(spin, damping)?;
        let lambdas = eigenvalues(&sm)?;
        let scale = lambdas.iter().map(|l| l.norm()).fold(omega.abs(), f64::max).max(f64::MIN_POSITIVE);
        let is_real = |l: &C64| l.im.abs() <= REAL_TOL * scale;
        let mut reals: Vec<f64> = lambdas.iter().filter(|l| is_real(l)).map(|l| l.re).collect();
        reals.sort_by(f64::total_cmp);
        // (representative, partner, kind)
        let mut picks: Vec<(C64, C64, ModeKind)> = Vec::new();
        if spin == Spin::Free
            && let Some((i, _)) = reals.iter().enumerate().min_by(|a, b| a.1.abs().total_cmp(&b.1.abs()))
        {
            let l = reals.remove(i);
            picks.push((C64::new(l, 0.0), C64::new(l, 0.0), ModeKind::SpinSpeed));
        }
        for l in lambdas.iter().filter(|l| !is_real(l) && l.im > 0.0) {
            picks.push((*l, l.conj(), ModeKind::Vibration));
        }
        for pair in reals.chunks(2) {
            let (a, b) = (pair[0], *pair.get(1).unwrap_or(&pair[0]));
            let (rep, other) = if a.abs() <= b.abs() { (a, b) } else { (b, a) };
            picks.push((C64::new(rep, 0.0), C64::new(other, 0.0), ModeKind::Vibration));
        }
        let mq = self.second_order(damping).m;
        let joints: Vec<String> = self.mech.joints.iter().map(|j| j.name.clone()).collect();
        let bodies: Vec<String> = self.mech.bodies.iter().map(|b| b.name.clone()).collect();
        let mut rigid = Vec::new();
        let mut modes = Vec::new();
        if spin == Spin::Free {
            let mut shape_q = vec![C64::new(0.0, 0.0); n];
            shape_q[s] = C64::new(1.0, 0.0);
            let mut share = vec![0.0; n];
            share[s] = 1.0;
            rigid.push(Mode {
                kind: ModeKind::SpinAngle,
                eigenvalue: C64::new(0.0, 0.0),
                partner: C64::new(0.0, 0.0),
                natural_frequency_rad_s: 0.0,
                damped_frequency_rad_s: 0.0,
                frequency_hz: 0.0,
                order: 0.0,
                damping_ratio: f64::NAN,
                shape_q,
                shape_qdot: vec![C64::new(0.0, 0.0); n],
                shape_u: vec![C64::new(0.0, 0.0); n],
                coordinate_share: share,
                body_energy_share: vec![0.0; n],
                label: joints[s].clone(),
            });
        }
        let mut used: Vec<C64> = Vec::new();
        for (rep, partner, kind) in picks {
            let k = used.iter().filter(|u| (**u - rep).norm() <= REPEAT_TOL * scale).count();
            used.push(rep);
            let v = null_vector(&sm, rep, k);
            let nq = qi.len();
            let mut q = vec![C64::new(0.0, 0.0); n];
            let mut u = vec![C64::new(0.0, 0.0); n];
            for (a, &j) in qi.iter().enumerate() {
                q[j] = v[a];
            }
            for (a, &j) in ui.iter().enumerate() {
                u[j] = v[nq + a];
            }
            if spin == Spin::Free && kind == ModeKind::Vibration && rep.norm() > 0.0 {
                // θ̇* = u_s*: the spin angle's part of the eigenvector.
                q[s] = u[s] / rep;
            }
            let mut qdot = vec![C64::new(0.0, 0.0); n];
            for k in 0..n {
                for r in 0..n {
                    qdot[k] += u[r] * self.w_inv[(k, r)];
                }
            }
            // Scale: largest q̇ entry made 1; for a zero-frequency mode (q̇ = λq ≈ 0, only rounding
            // left in q̇) the displacement q stands in for q̇ in the scaling and the shares.
            let moving = rep.norm() > REPEAT_TOL * scale || kind == ModeKind::SpinSpeed;
            let basis = if moving { &qdot } else { &q };
            let pivot = basis
                .iter()
                .copied()
                .max_by(|a, b| a.norm().total_cmp(&b.norm()))
                .filter(|p| p.norm() > 0.0)
                .unwrap_or(C64::new(1.0, 0.0));
            for x in q.iter_mut().chain(u.iter_mut()).chain(qdot.iter_mut()) {
                *x /= pivot;
            }
            let basis = if moving { &qdot } else { &q };
            let mut share: Vec<f64> = (0..n).map(|j| basis[j].norm_sqr() * mq[(j, j)]).collect();
            normalise(&mut share);
            let mut energy: Vec<f64> = (0..n)
                .map(|j| {
                    let (pv, pw) = &self.partials[j];
                    let (mut vx, mut vy, mut w) = (C64::new(0.0, 0.0), C64::new(0.0, 0.0), C64::new(0.0, 0.0));
                    for r in 0..n {
                        vx += u[r] * pv[r].x;
                        vy += u[r] * pv[r].y;
                        w += u[r] * pw[r];
                    }
                    let b = &self.mech.bodies[j].inertia;
                    0.5 * (b.mass * (vx.norm_sqr() + vy.norm_sqr()) + b.i_com * w.norm_sqr())
                })
                .collect();
            normalise(&mut energy);
            let top = share.iter().enumerate().max_by(|a, b| a.1.total_cmp(b.1)).map_or(0, |(j, _)| j);
            let (wn, zeta) = if rep.im != 0.0 {
                (rep.norm(), if rep.norm() > 0.0 { -rep.re / rep.norm() } else { f64::NAN })
            } else {
                let wn = (rep.re * partner.re).abs().sqrt();
                (wn, if wn > 0.0 { -(rep.re + partner.re) / (2.0 * wn) } else { f64::NAN })
            };
            let wd = rep.im.abs();
            let mode = Mode {
                kind,
                eigenvalue: rep,
                partner,
                natural_frequency_rad_s: wn,
                damped_frequency_rad_s: wd,
                frequency_hz: wd / (2.0 * PI),
                order: if omega != 0.0 { wd / omega.abs() } else { f64::NAN },
                damping_ratio: zeta,
                shape_q: q,
                shape_qdot: qdot,
                shape_u: u,
                coordinate_share: share,
                body_energy_share: energy,
                label: joints[top].clone(),
            };
            if kind == ModeKind::SpinSpeed {
                let mut mode = mode;
                mode.shape_q[s] = C64::new(0.0, 0.0);
                mode.label = joints[s].clone();
                rigid.push(mode);
            } else {
                modes.push(mode);
            }
        }
        modes.sort_by(|a, b| a.natural_frequency_rad_s.total_cmp(&b.natural_frequency_rad_s));
        let stable = lambdas.iter().all(|l| l.re <= 1e-9 * scale);
        Ok(Modal { omega, spin, damping, joints, bodies, rigid, modes, stable })
    }

    /// Complex amplitude of body `body`'s angular acceleration (rad/s² per N·m) for a unit torque
    /// `e^{iΩnt}` in joint `joint`, spin free: eq. (22) on the full 2n state,
    /// `α̂ = iΩn · c·û` with c the body's angular-velocity row.
    pub fn acceleration_response(&self, body: usize, joint: usize, order: f64) -> LinResult<C64> {
        let n = self.ndof();
        let w = self.op.omega * order;
        let iw = C64::new(0.0, w);
        let mut k = DMatrix::from_element(2 * n, 2 * n, C64::new(0.0, 0.0));
        for i in 0..n {
            k[(i, i)] = iw;
            for j in 0..n {
                k[(i, n + j)] = C64::new(-self.w_inv[(i, j)], 0.0);
                k[(n + i, j)] = C64::new(-self.f_q[(i, j)], 0.0);
                k[(n + i, n + j)] = iw * self.mass[(i, j)] - self.f_u[(i, j)];
            }
        }
        let g = self.generalized_torque(joint);
        let rhs = DVector::from_fn(2 * n, |i, _| C64::new(if i >= n { g[i - n] } else { 0.0 }, 0.0));
        let x = k.lu().solve(&rhs).ok_or(LinearError::Singular { order })?;
        if x.iter().any(|v| !v.re.is_finite() || !v.im.is_finite()) {
            return Err(LinearError::Singular { order });
        }
        let c = self.angular_velocity_row(body);
        let mut om = C64::new(0.0, 0.0);
        for r in 0..n {
            om += x[n + r] * c[r];
        }
        Ok(iw * om)
    }

    /// The high-order limit of the acceleration response: `c·M⁰⁻¹·g`, rad/s² per N·m (inertia
    /// only: stiffness and damping vanish against ω²M and ωM as ω → ∞).
    pub fn acceleration_limit(&self, body: usize, joint: usize) -> LinResult<f64> {
        let chol = self
            .mass
            .clone()
            .cholesky()
            .ok_or_else(|| LinearError::MassMatrix { mechanism: self.mech.name.clone() })?;
        Ok(self.angular_velocity_row(body).dot(&chol.solve(&self.generalized_torque(joint))))
    }
}

fn normalise(v: &mut [f64]) {
    let s: f64 = v.iter().sum();
    if s > 0.0 {
        v.iter_mut().for_each(|x| *x /= s);
    }
}

/// Eigenvalues of a real square matrix: balanced (Parlett–Reinsch), then real Schur form.
fn eigenvalues(s: &DMatrix<f64>) -> LinResult<Vec<C64>> {
    let d = s.nrows();
    match d {
        0 => return Ok(Vec::new()),
        1 => return Ok(vec![C64::new(s[(0, 0)], 0.0)]),
        _ => {}
    }
    let mut b = s.clone();
    nalgebra::linalg::balancing::balance_parlett_reinsch(&mut b);
    let schur = nalgebra::Schur::try_new(b, f64::EPSILON, 100_000).ok_or(LinearError::Eigen { dim: d })?;
    Ok(schur.complex_eigenvalues().iter().copied().collect())
}

/// The right singular vector of `S − λI` with the (k+1)-th smallest singular value: the
/// eigenvector for k = 0, further null vectors of a repeated eigenvalue for k ≥ 1.
fn null_vector(s: &DMatrix<f64>, lambda: C64, k: usize) -> Vec<C64> {
    let d = s.nrows();
    let a = DMatrix::from_fn(d, d, |i, j| C64::new(s[(i, j)], 0.0) - if i == j { lambda } else { C64::new(0.0, 0.0) });
    let svd = a.svd(false, true);
    let Some(vt) = svd.v_t else {
        return vec![C64::new(0.0, 0.0); d];
    };
    let mut order: Vec<usize> = (0..svd.singular_values.len()).collect();
    order.sort_by(|&a, &b| svd.singular_values[a].total_cmp(&svd.singular_values[b]));
    let row = order[k.min(d - 1)];
    (0..d).map(|j| vt[(row, j)].conj()).collect()
}

/// Which joint excites, which body is watched, and which joints are locked for the reference.
#[derive(Debug, Clone, PartialEq)]
pub struct ResponseSpec {
    /// The spin joint (root joint turning at Ω).
    pub spin_joint: String,
    /// The joint carrying the unit torque (e.g. the spin joint for the engine torque).
    pub input_joint: String,
    /// The body whose angular acceleration is the response (e.g. `rotor`).
    pub body: String,
    /// Joints locked (at their operating-point angles) to build the reference mechanism, e.g. the
    /// pendulum pivots. A locked child merges into its parent; if `body` is merged away, the
    /// response is that of the body that absorbed it.
    pub lock: Vec<String>,
}

/// One point of an order sweep of the frequency response.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct FrfPoint {
    /// Excitation order n.
    pub order: f64,
    /// |α̂| of the body, rad/s² per N·m.
    pub response: f64,
    /// |α̂| of the locked mechanism's body, rad/s² per N·m.
    pub locked: f64,
    /// `response / locked` (Fig. 2).
    pub ratio: f64,
}

/// The extremes of the normalised response over an order range.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Extremes {
    /// Order of the smallest ratio.
    pub min_order: f64,
    /// The smallest ratio.
    pub min_ratio: f64,
    /// Order of the largest ratio.
    pub max_order: f64,
    /// The largest ratio (very large near an undamped resonance).
    pub max_ratio: f64,
}

/// The frequency response of a mechanism and of its locked twin at one spin speed (Fig. 2).
#[derive(Debug, Clone)]
pub struct OrderResponse {
    /// The mechanism.
    pub model: LinearModel,
    /// The locked mechanism.
    pub locked: LinearModel,
    body: usize,
    input: usize,
    body_locked: usize,
    input_locked: usize,
}

impl OrderResponse {
    /// Linearises `mech` and its locked twin at `omega_rad_s` (spin free).
    pub fn new(mech: &Mechanism, spec: &ResponseSpec, omega_rad_s: f64, guess: Option<&[f64]>) -> LinResult<Self> {
        let model = LinearModel::new(mech, &spec.spin_joint, omega_rad_s, guess)?;
        let body = body_of(mech, &spec.body)?;
        let input = joint_of(mech, &spec.input_joint)?;
        let mut lm = mech.clone();
        let mut watched = spec.body.clone();
        for name in &spec.lock {
            if *name == spec.input_joint {
                return Err(LinearError::LockedInput { joint: name.clone() });
            }
            let c = joint_of(&lm, name)?;
            let q_lock = model.op.q[joint_of(mech, name)?];
            if lm.bodies[c].name == watched
                && let Some(p) = lm.joints[c].parent
            {
                watched = lm.bodies[p].name.clone();
            }
            lm = lm.lock(name, q_lock)?;
        }
        let guess_l: Vec<f64> =
            lm.joints.iter().map(|j| mech.joint_index(&j.name).map_or(0.0, |k| model.op.q[k])).collect();
        let locked = LinearModel::new(&lm, &spec.spin_joint, omega_rad_s, Some(&guess_l))?;
        let body_locked = body_of(&lm, &watched)?;
        let input_locked = joint_of(&lm, &spec.input_joint)?;
        Ok(Self { model, locked, body, input, body_locked, input_locked })
    }

    /// Complex α̂ of the body per N·m at order n.
    pub fn response(&self, order: f64) -> LinResult<C64> {
        self.model.acceleration_response(self.body, self.input, order)
    }

    /// Complex α̂ of the locked mechanism's body per N·m at order n.
    pub fn locked_response(&self, order: f64) -> LinResult<C64> {
        self.locked.acceleration_response(self.body_locked, self.input_locked, order)
    }

    /// Both magnitudes and their ratio at order n.
    pub fn point(&self, order: f64) -> LinResult<FrfPoint> {
        let response = self.response(order)?.norm();
        let locked = self.locked_response(order)?.norm();
        Ok(FrfPoint { order, response, locked, ratio: response / locked })
    }

    /// [`OrderResponse::point`] over a list of orders.
    pub fn sweep(&self, orders: &[f64]) -> LinResult<Vec<FrfPoint>> {
        orders.iter().map(|&n| self.point(n)).collect()
    }

    /// The normalised response as n → ∞: the ratio of the inertia-only responses
    /// ([`LinearModel::acceleration_limit`]); for the CPVA `(Ĩ + 1 + 2n_t²)/(Ĩ − n_t⁴)`.
    pub fn asymptote(&self) -> LinResult<f64> {
        Ok(self.model.acceleration_limit(self.body, self.input)?.abs()
            / self.locked.acceleration_limit(self.body_locked, self.input_locked)?.abs())
    }

    fn ratio(&self, n: f64) -> f64 {
        // An exact hit of an undamped pole counts as an infinite response.
        self.point(n).map_or(f64::INFINITY, |p| p.ratio)
    }

    /// The first order in `[n_from, n_to]` where the normalised response rises through 1 (from
    /// below): located on a grid of `steps` intervals, then bisected to 1e-13 relative.
    /// `None` when it does not happen in the range.
    pub fn first_amplification(&self, n_from: f64, n_to: f64, steps: usize) -> LinResult<Option<f64>> {
        if !(n_to > n_from && steps > 0) {
            return Err(LinearError::Invalid(format!("order range [{n_from}, {n_to}] with {steps} steps")));
        }
        let at = |i: usize| n_from + (n_to - n_from) * i as f64 / steps as f64;
        let mut prev = self.ratio(n_from);
        for i in 1..=steps {
            let cur = self.ratio(at(i));
            if prev <= 1.0 && cur > 1.0 {
                let (mut lo, mut hi) = (at(i - 1), at(i));
                while hi - lo > 1e-13 * hi.abs().max(1.0) {
                    let mid = 0.5 * (lo + hi);
                    if self.ratio(mid) > 1.0 {
                        hi = mid;
                    } else {
                        lo = mid;
                    }
                }
                return Ok(Some(0.5 * (lo + hi)));
            }
            prev = cur;
        }
        Ok(None)
    }

    /// Smallest and largest normalised response over `[n_from, n_to]`: a grid of `steps`
    /// intervals, then golden-section search in the two intervals around the best grid point
    /// (to 1e-10 relative in n).
    pub fn extremes(&self, n_from: f64, n_to: f64, steps: usize) -> LinResult<Extremes> {
        if !(n_to > n_from && steps >= 2) {
            return Err(LinearError::Invalid(format!("order range [{n_from}, {n_to}] with {steps} steps")));
        }
        let grid: Vec<f64> = (0..=steps).map(|i| n_from + (n_to - n_from) * i as f64 / steps as f64).collect();
        let vals: Vec<f64> = grid.iter().map(|&n| self.ratio(n)).collect();
        let refine = |sign: f64| -> (f64, f64) {
            let i = (0..vals.len()).max_by(|&a, &b| (sign * vals[a]).total_cmp(&(sign * vals[b]))).unwrap_or(0);
            let (a, b) = (grid[i.saturating_sub(1)], grid[(i + 1).min(steps)]);
            let (n, v) = golden(|n| -sign * self.ratio(n), a, b);
            if -v * sign >= vals[i] * sign { (n, -sign * v) } else { (grid[i], vals[i]) }
        };
        let (max_order, max_ratio) = refine(1.0);
        let (min_order, min_ratio) = refine(-1.0);
        Ok(Extremes { min_order, min_ratio, max_order, max_ratio })
    }
}

/// Golden-section minimisation of `f` on `[a, b]`; returns (argmin, min).
fn golden(f: impl Fn(f64) -> f64, mut a: f64, mut b: f64) -> (f64, f64) {
    let r = (5f64.sqrt() - 1.0) / 2.0;
    let mut c = b - r * (b - a);
    let mut d = a + r * (b - a);
    let (mut fc, mut fd) = (f(c), f(d));
    while (b - a) > 1e-10 * b.abs().max(1.0) {
        if fc < fd {
            b = d;
            d = c;
            fd = fc;
            c = b - r * (b - a);
            fc = f(c);
        } else {
            a = c;
            c = d;
            fc = fd;
            d = a + r * (b - a);
            fd = f(d);
        }
    }
    if fc < fd { (c, fc) } else { (d, fd) }
}

/// One tracked mode over the speeds of a Campbell diagram.
#[derive(Debug, Clone, PartialEq)]
pub struct CampbellTrack {
    /// The most frequent label along the track (joint with the largest coordinate share).
    pub label: String,
    /// The label at each speed.
    pub labels: Vec<String>,
    /// Damped natural frequency |Im λ|/2π at each speed, Hz.
    pub frequency_hz: Vec<f64>,
    /// Undamped natural frequency ω_n/2π at each speed, Hz.
    pub natural_frequency_hz: Vec<f64>,
    /// Damping ratio at each speed.
    pub damping_ratio: Vec<f64>,
}

/// An engine-order line `f = n·rpm/60`.
#[derive(Debug, Clone, PartialEq)]
pub struct OrderLine {
    /// The order n.
    pub order: f64,
    /// Its frequency at each speed, Hz.
    pub frequency_hz: Vec<f64>,
}

/// Campbell data: natural frequencies against spin speed, with order lines.
#[derive(Debug, Clone, PartialEq)]
pub struct Campbell {
    /// Spin speeds, rpm.
    pub rpm: Vec<f64>,
    /// The n − 1 vibration modes, tracked across speeds.
    pub tracks: Vec<CampbellTrack>,
    /// The order lines.
    pub order_lines: Vec<OrderLine>,
}

/// Modal assurance criterion of two complex shapes, in [0, 1].
fn mac(a: &[C64], b: &[C64]) -> f64 {
    let dot: C64 = a.iter().zip(b).map(|(x, y)| x.conj() * y).sum();
    let na: f64 = a.iter().map(|x| x.norm_sqr()).sum();
    let nb: f64 = b.iter().map(|x| x.norm_sqr()).sum();
    if na == 0.0 || nb == 0.0 { 0.0 } else { dot.norm_sqr() / (na * nb) }
}

/// Campbell data of `mech` spinning on `spin_joint` over `rpm` (each speed linearised from the
/// previous speed's equilibrium, the first from `guess`), with the order lines of `orders`.
///
/// Tracking: at the first speed the modes are sorted by natural frequency; at each next speed
/// each track takes the mode whose coordinate shape q has the largest MAC with the track's
/// previous shape (greedy, largest MAC first). This follows a mode through a crossing with
/// another as long as the shapes stay distinct; repeated roots (identical pendulums) have no
/// unique shapes and are tracked by order only.
pub fn campbell(
    mech: &Mechanism,
    spin_joint: &str,
    rpm: &[f64],
    orders: &[f64],
    spin: Spin,
    damping: Damping,
    guess: Option<&[f64]>,
) -> LinResult<Campbell> {
    let mut guess: Option<Vec<f64>> = guess.map(<[f64]>::to_vec);
    let mut tracks: Vec<CampbellTrack> = Vec::new();
    let mut last: Vec<Vec<C64>> = Vec::new();
    for (i, &r) in rpm.iter().enumerate() {
        let model = LinearModel::new(mech, spin_joint, rpm_to_rad_s(r), guess.as_deref())?;
        guess = Some(model.op.q.clone());
        let modal = model.modes(spin, damping)?;
        if i == 0 {
            for m in &modal.modes {
                tracks.push(CampbellTrack {
                    label: String::new(),
                    labels: vec![m.label.clone()],
                    frequency_hz: vec![m.frequency_hz],
                    natural_frequency_hz: vec![m.natural_frequency_rad_s / (2.0 * PI)],
                    damping_ratio: vec![m.damping_ratio],
                });
                last.push(m.shape_q.clone());
            }
            continue;
        }
        let mut pairs: Vec<(f64, usize, usize)> = Vec::new();
        for (t, shape) in last.iter().enumerate() {
            for (m, mode) in modal.modes.iter().enumerate() {
                pairs.push((mac(shape, &mode.shape_q), t, m));
            }
        }
        pairs.sort_by(|a, b| b.0.total_cmp(&a.0));
        let mut t_done = vec![false; tracks.len()];
        let mut m_done = vec![false; modal.modes.len()];
        for (_, t, m) in pairs {
            if t_done[t] || m_done[m] {
                continue;
            }
            t_done[t] = true;
            m_done[m] = true;
            let mode = &modal.modes[m];
            let tr = &mut tracks[t];
            tr.labels.push(mode.label.clone());
            tr.frequency_hz.push(mode.frequency_hz);
            tr.natural_frequency_hz.push(mode.natural_frequency_rad_s / (2.0 * PI));
            tr.damping_ratio.push(mode.damping_ratio);
            last[t] = mode.shape_q.clone();
        }
    }
    for tr in &mut tracks {
        let mut best = (0, String::new());
        for l in &tr.labels {
            let c = tr.labels.iter().filter(|x| *x == l).count();
            if c > best.0 {
                best = (c, l.clone());
            }
        }
        tr.label = best.1;
    }
    let order_lines = orders
        .iter()
        .map(|&n| OrderLine { order: n, frequency_hz: rpm.iter().map(|&r| n * r / 60.0).collect() })
        .collect();
    Ok(Campbell { rpm: rpm.to_vec(), tracks, order_lines })
}

/// The torque harmonics at one speed of a multi-order load case (the paper's Table 1 row).
#[derive(Debug, Clone, PartialEq)]
pub struct SpeedCase {
    /// Spin speed, rpm.
    pub rpm: f64,
    /// Harmonics `T_k sin(k·nΩt + α_k)` of the base order n (multiple k, amplitude N·m, phase rad).
    pub harmonics: Vec<Harmonic>,
}

/// The steady response to one harmonic of a multi-order torque.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct HarmonicResponse {
    /// Multiple k of the base order.
    pub multiple: f64,
    /// Excitation order k·n.
    pub order: f64,
    /// Torque amplitude T_k, N·m.
    pub torque: f64,
    /// Amplitude of the body's angular acceleration at this order, rad/s².
    pub amplitude: f64,
    /// Its phase: the response is `amplitude·sin(k·nΩt + phase)`, rad.
    pub phase: f64,
    /// Amplitude for the locked mechanism, rad/s².
    pub locked_amplitude: f64,
    /// Phase for the locked mechanism, rad.
    pub locked_phase: f64,
}

/// The linear steady multi-order response at one speed.
#[derive(Debug, Clone, PartialEq)]
pub struct SpeedResponse {
    /// Speed, rpm.
    pub rpm: f64,
    /// Speed, rad/s.
    pub omega: f64,
    /// Mean torque holding the speed, N·m.
    pub mean_torque: f64,
    /// Per harmonic.
    pub harmonics: Vec<HarmonicResponse>,
    /// Peak |α(t)| of the superposed harmonics over one revolution of the base-order phase
    /// (sampled at 4096 points per revolution, times the largest multiple); None when a multiple
    /// is not an integer (no common period).
    pub peak: Option<f64>,
    /// The same for the locked mechanism.
    pub locked_peak: Option<f64>,
}

fn superposed_peak(h: &[(f64, f64, f64)]) -> Option<f64> {
    if h.iter().any(|&(k, _, _)| (k - k.round()).abs() > 1e-12) {
        return None;
    }
    let kmax = h.iter().fold(1.0f64, |a, &(k, _, _)| a.max(k.abs()));
    let samples = PEAK_SAMPLES * kmax.ceil() as usize;
    let mut peak = 0.0f64;
    for i in 0..samples {
        let phi = 2.0 * PI * i as f64 / samples as f64;
        let v: f64 = h.iter().map(|&(k, a, p)| a * (k * phi + p).sin()).sum();
        peak = peak.max(v.abs());
    }
    Some(peak)
}

/// The linear steady-state response per order of `spec.body`'s angular acceleration to the
/// multi-order torque of each speed case (eq. 24 at base order `base_order`), superposing the
/// harmonics each through the frequency response at its own order, with the locked comparison
/// (Fig. 5 in the linear approximation). Each speed is linearised from the previous one's
/// equilibrium.
pub fn multi_order_response(
    mech: &Mechanism,
    spec: &ResponseSpec,
    base_order: f64,
    cases: &[SpeedCase],
    guess: Option<&[f64]>,
) -> LinResult<Vec<SpeedResponse>> {
    let mut guess: Option<Vec<f64>> = guess.map(<[f64]>::to_vec);
    let mut out = Vec::with_capacity(cases.len());
    for case in cases {
        let omega = rpm_to_rad_s(case.rpm);
        let resp = OrderResponse::new(mech, spec, omega, guess.as_deref())?;
        guess = Some(resp.model.op.q.clone());
        let mut harmonics = Vec::with_capacity(case.harmonics.len());
        for h in &case.harmonics {
            let order = h.multiple * base_order;
            // sin(ψ + α) = Im e^{i(ψ+α)}: the response is Im(H T e^{i(ψ+α)}).
            let a = resp.response(order)?;
            let l = resp.locked_response(order)?;
            harmonics.push(HarmonicResponse {
                multiple: h.multiple,
                order,
                torque: h.amplitude,
                amplitude: a.norm() * h.amplitude.abs(),
                phase: h.phase + a.arg() + if h.amplitude < 0.0 { PI } else { 0.0 },
                locked_amplitude: l.norm() * h.amplitude.abs(),
                locked_phase: h.phase + l.arg() + if h.amplitude < 0.0 { PI } else { 0.0 },
            });
        }
        let peak = superposed_peak(&harmonics.iter().map(|h| (h.multiple, h.amplitude, h.phase)).collect::<Vec<_>>());
        let locked_peak = superposed_peak(
            &harmonics.iter().map(|h| (h.multiple, h.locked_amplitude, h.locked_phase)).collect::<Vec<_>>(),
        );
        out.push(SpeedResponse {
            rpm: case.rpm,
            omega,
            mean_torque: resp.model.op.mean_spin_torque,
            harmonics,
            peak,
            locked_peak,
        });
    }
    Ok(out)
}

/// The same mechanism with another choice of generalized speeds. No result of this module (eigen-
/// orders, shapes in q, responses of body accelerations) depends on that choice; this is for
/// checking exactly that.
pub fn with_speeds(mech: &Mechanism, speeds: Speeds) -> Mechanism {
    Mechanism { speeds, ..mech.clone() }
}
