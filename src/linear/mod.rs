//! Linear analysis of any mechanism about a steady spin: linearisation (paper §2.3, eq. 13),
//! the first-order form `M ẋ + A x = T` (eq. 19), eigen-orders and mode shapes, the order-domain
//! frequency response `x̂ = (iΩnM + A)⁻¹ â` (eq. 22) normalised by the locked mechanism (Fig. 2),
//! Campbell data and the linear multi-order response over speed (§4.2, Table 1). Design notes:
//! `docs/design/linear.md`.
//!
//! This module holds the operating point, the Jacobians and [`LinearModel`] with its first- and
//! second-order forms; the analyses are in submodules, all re-exported here: `modes` (eigen-orders
//! and shapes), `response` (the order-domain response, eq. 22), `gravity` (the order-1 response to
//! gravity at the nominal rotation), `campbell` and `multi_order` (eq. 24).
//!
//! # The operating point
//! One root joint, the *spin joint* s, turns at the constant rate Ω (rad/s); every other joint j
//! sits at a relative equilibrium `q_j = q⁰_j`, `q̇_j = 0`, so `u⁰ = W q̇⁰` with `q̇⁰ = Ω e_s`
//! (with absolute angular velocities as speeds every body of the spinning subtree has u⁰ = Ω, as
//! in the paper's eqs. 9 and 11). In a geared mechanism whose meshes pass the rotation on, the
//! joints meshed to the spin turn with it: `q̇⁰ = Ω z`, z the rigid rotation
//! ([`Mechanism::rigid_rotation`], docs/design/model.md "Gears"), and what is said of the spin angle
//! below holds of the angle along z. The spin angle must be *cyclic*: F may not depend on it. That
//! holds when the spin joint has no spring ([`LinearError::SpinSpring`] otherwise) and no load
//! needs the world orientation. Gravity and world-frame forces do: with them the steady spin is
//! not an equilibrium, the motion is periodic in the rotor angle. They are taken out of the
//! linearisation and put back as what they are at first order, a forcing of order 1 exactly
//! ([`LinearModel::gravity_force`], the `gravity` submodule: the gravity-forced response through
//! eq. 22, the parametric gravity × deflection term neglected as second order).
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
//! W⁻¹. The joint couplings ([`crate::model::coupling`]) are the exception: not smooth on the
//! scale of these steps, they are left out of the differences and their exact local derivatives
//! added ([`Kane::add_coupling_jacobians`]): a staged spring contributes the stiffness of the
//! stage the operating point sits in, an end stop nothing unless engaged, and friction, at the
//! zero relative rate of a relative equilibrium, the viscous damper T_f/ε. That last one is a
//! limit of the method: the linear model of a friction joint is a damper whose size depends on
//! the smoothing ε, not on T_f's Coulomb behaviour, and says nothing about stick-slip.
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

mod bounded;
mod campbell;
mod damping;
mod element_law;
mod gravity;
mod modes;
mod multi_order;
mod response;

pub use campbell::{
    CROSSING_RTOL, Campbell, CampbellOptions, CampbellTrack, Crossing, OrderLine, campbell, campbell_with,
};
pub use damping::{ModalCombination, ModalDamping};
pub use element_law::{ElementLaw, element_law};
pub use modes::{Modal, Mode, ModeKind};
pub use multi_order::{
    ElementLines, GravityLine, HarmonicResponse, MultiOrderOptions, SpeedCase, SpeedResponse, multi_order_response,
    multi_order_response_with,
};
pub use response::{Extremes, FrfPoint, Input, OrderResponse, ResponseSpec};

use crate::error::Error;
use crate::kane::Kane;
use crate::model::excitation::Excitation;
use crate::model::math::Vec2;
use crate::model::mechanism::Mechanism;
use crate::model::speeds::Speeds;
use nalgebra::{Complex, DMatrix, DVector};

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
    /// Gravity or a world-frame force whose generalized force at the nominal rotation is not a
    /// pure order-1 harmonic of the spin angle (it loads a body that does not turn with the spin
    /// joint, or turns at another rate): the linear analysis has no steady state to expand about.
    #[error(
        "mechanism `{mechanism}`: gravity or a world-frame force is not a pure order-1 forcing of the steady rotation ({detail}); the linear analysis takes gravity only on bodies that turn with the spin joint (use a time-domain analysis, or a harmonic balance continued in speed or torque)"
    )]
    WorldOrientation {
        /// Mechanism name.
        mechanism: String,
        /// What was found.
        detail: String,
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
    /// The analysis passed the watchdog's deadline ([`crate::deadline::Deadline`]).
    #[error("stopped by the watchdog {reached}: {}", crate::deadline::Deadline::overran(*budget_s))]
    Watchdog {
        /// Where it had got to (`at 1200 rpm after 40 of 1000 speeds`).
        reached: String,
        /// The budget, s of wall time.
        budget_s: f64,
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
    /// Index of the spin joint.
    pub spin_joint: usize,
    /// Index of the spin joint's coordinate (differs from the joint's when a welded joint
    /// precedes it).
    pub spin_coordinate: usize,
    /// The rigid rotation z ([`Mechanism::rigid_rotation`]): each coordinate's rate per unit spin
    /// rate in the steady motion `q⁰ + Ωt z` (1 at the spin coordinate, the gear ratios at the
    /// joints meshed to it, 0 elsewhere).
    pub rotation: Vec<f64>,
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
    /// Complex amplitude `F̂_g` of the generalized force of gravity and world-frame forces at the
    /// nominal rotation (n entries, rows of u; N·m, N for a slide): `F_g(t) = Re(F̂_g e^{iΩt})`,
    /// order 1 exactly (see `gravity`'s module docs); zero without such loads. It is not part
    /// of the linearisation (the operating point and Jacobians are those without gravity).
    pub gravity_force: DVector<C64>,
    gravity_loaded: bool,
    partials: Vec<(Vec<Vec2>, Vec<f64>)>,
}

/// The Jacobians `(∂F/∂q, ∂F/∂u)` of the engine's forcing at `(q, u)`, t = 0, by central
/// differences with two Richardson extrapolations (steps h, h/2, h/4, error O(h⁶)): h = 0.05 rad
/// for the angles (0.05 m for slides, 0.05 times the joint kind's `coordinate_scale` for a path's arc
/// length), h = 0.05·max(1, |u|) for the speeds (F is quadratic in u, so the central
/// difference is exact there up to rounding). Time-dependent torques are frozen at t = 0.
pub fn forcing_jacobians(kane: &mut Kane, q: &[f64], u: &[f64]) -> (DMatrix<f64>, DMatrix<f64>) {
    let h_u = H_SPEED_REL * u.iter().fold(1.0f64, |a, &b| a.max(b.abs()));
    // Steps in each coordinate's own scale: H_ANGLE rad for an angle or a slide, H_ANGLE times a
    // path's length scale for an arc length (a path of 15 mm would be left, or badly resolved, by
    // a step of 0.05 m).
    let mech = kane.mechanism();
    let h_q: Vec<f64> = (0..q.len()).map(|k| H_ANGLE * mech.joints[mech.joint_of(k)].kind.coordinate_scale()).collect();
    // The joint couplings (staged springs, friction, stops) are not smooth on the scale of these
    // steps (a stage breakpoint 0.01 rad away, a friction smoothing of 0.01 rad/s): their
    // derivatives are added exactly instead, so the model sees the local stiffness of the stage
    // at the operating point and friction as the viscous damper T_f/ε.
    let suspended = kane.suspend_couplings();
    let mut f_q = richardson_jacobian(q, &h_q, |x| kane.forcing(0.0, x, u).clone());
    let mut f_u = richardson_jacobian(u, &vec![h_u; u.len()], |x| kane.forcing(0.0, q, x).clone());
    kane.restore_couplings(suspended);
    if kane.has_couplings() {
        let n = q.len();
        let (mut dq, mut du) = (vec![0.0; n * n], vec![0.0; n * n]);
        kane.add_coupling_jacobians(q, u, &mut dq, &mut du);
        f_q += DMatrix::from_row_slice(n, n, &dq);
        f_u += DMatrix::from_row_slice(n, n, &du);
    }
    (f_q, f_u)
}

/// Central differences at h, h/2, h/4 combined as `R2 = (16 R1(h/2) − R1(h))/15` with
/// `R1(h) = (4 D(h/2) − D(h))/3`: the h² and h⁴ error terms cancel.
fn richardson_jacobian(x0: &[f64], h: &[f64], mut f: impl FnMut(&[f64]) -> DVector<f64>) -> DMatrix<f64> {
    let mut x = x0.to_vec();
    let mut cols = Vec::with_capacity(x0.len());
    for j in 0..x0.len() {
        let mut d: Vec<DVector<f64>> = Vec::with_capacity(3);
        for level in 0..3 {
            let hl = h[j] / f64::from(1u32 << level);
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

/// The error for a joint or body name that `mech` does not have, listing the known names.
fn unknown(mech: &Mechanism, what: &'static str, name: &str) -> LinearError {
    let known: Vec<&str> = if what == "joint" {
        mech.joints.iter().map(|j| j.name.as_str()).collect()
    } else {
        mech.bodies.iter().map(|b| b.name.as_str()).collect()
    };
    LinearError::Unknown { mechanism: mech.name.clone(), what, name: name.into(), known: known.join(", ") }
}

/// Index of joint `name` of `mech`.
fn joint_of(mech: &Mechanism, name: &str) -> LinResult<usize> {
    mech.joint_index(name).ok_or_else(|| unknown(mech, "joint", name))
}

/// Index of body `name` of `mech`.
fn body_of(mech: &Mechanism, name: &str) -> LinResult<usize> {
    mech.body_index(name).ok_or_else(|| unknown(mech, "body", name))
}

/// The mechanism at its operating point's loads: applied torques frozen at their means, the spin
/// joint's torque removed (T_m is solved for), gravity and world-frame forces removed (they force
/// the linear model at order 1 instead, [`LinearModel::gravity_force`]).
fn prepare(mech: &Mechanism, spin: usize) -> Mechanism {
    let mut m = mech.clone();
    m.loads.joint_torques.retain(|t| t.joint != spin);
    m.loads.gravity = Vec2::zeros();
    m.loads.point_forces.retain(|p| p.frame != crate::model::loads::ForceFrame::World);
    for t in &mut m.loads.joint_torques {
        t.excitation = Excitation::constant(t.excitation.mean);
    }
    m
}

/// The same mechanism without dampers (joint dampers, ground dampers, joint friction and the end
/// stops' contact damping).
fn undamped(mech: &Mechanism) -> Mechanism {
    let mut m = mech.clone();
    for j in &mut m.joints {
        j.damper = 0.0;
        // Friction and the stops' contact damping are dampers too (friction linearises to T_f/ε).
        j.couplings.friction = None;
        if let Some(s) = &mut j.couplings.stops {
            s.damping = 0.0;
        }
    }
    m.loads.ground_dampers.clear();
    for mesh in m.gears.iter_mut().filter_map(|g| g.mesh.as_mut()) {
        mesh.damping = 0.0;
    }
    m
}

/// The spin joint named `spin_joint` (its joint index and coordinate): a rotating root joint
/// that nothing holds to ground (no spring, staged spring or end stops).
fn spin_of(mech: &Mechanism, spin_joint: &str) -> LinResult<(usize, usize)> {
    let sj = joint_of(mech, spin_joint)?;
    if mech.joints[sj].parent.is_some() {
        return Err(LinearError::SpinNotRoot { mechanism: mech.name.clone(), joint: spin_joint.into() });
    }
    let Some(s) = mech.coordinate(sj).filter(|_| mech.joints[sj].kind.rotates()) else {
        return Err(LinearError::Invalid(format!("spin joint `{spin_joint}` does not rotate: it cannot spin")));
    };
    if let Some(sp) = mech.joints[sj].spring
        && sp.stiffness != 0.0
    {
        return Err(LinearError::SpinSpring {
            mechanism: mech.name.clone(),
            joint: spin_joint.into(),
            stiffness: sp.stiffness,
        });
    }
    // A staged spring or end stops on the spin joint hold it to ground as a spring does.
    let c = &mech.joints[sj].couplings;
    let held = c.stages.as_ref().map(|st| st.drive[0].stiffness).or(c.stops.map(|st| st.stiffness));
    if let Some(stiffness) = held {
        return Err(LinearError::SpinSpring { mechanism: mech.name.clone(), joint: spin_joint.into(), stiffness });
    }
    Ok((sj, s))
}

/// Newton for the relative equilibrium at speed `omega` of spin coordinate `s` (`spin`): the
/// other coordinates `q` (updated in place from the guess) and the mean spin torque T_m that
/// together make the accelerations vanish at the speeds `u`. Returns (T_m, the residual
/// acceleration, the iterations); no convergence (or NaN) is an error.
fn relative_equilibrium(
    kane: &mut Kane,
    mech: &Mechanism,
    q: &mut [f64],
    u: &[f64],
    g_s: &DVector<f64>,
    spin: (usize, f64),
) -> LinResult<(f64, f64, usize)> {
    let n = q.len();
    let (s, omega_rad_s) = spin;
    // Newton on z = [q_j (j ≠ s); T_m] for r(z) = F(q, u⁰) + T_m g_s = 0.
    let others: Vec<usize> = (0..n).filter(|&j| j != s).collect();
    let scale = 1.0 + omega_rad_s * omega_rad_s;
    let mut t_m = 0.0;
    let mut iterations = 0;
    let accel = |kane: &mut Kane, q: &[f64], t_m: f64| -> LinResult<(DVector<f64>, f64)> {
        let r = kane.forcing(0.0, q, u).clone() + g_s * t_m;
        let chol = kane
            .mass_matrix(q)
            .clone()
            .cholesky()
            .ok_or_else(|| LinearError::MassMatrix { mechanism: mech.name.clone() })?;
        let udot = chol.solve(&r);
        Ok((r, udot.amax()))
    };
    let (mut r, mut residual) = accel(kane, q, t_m)?;
    while residual > NEWTON_TIGHT * scale && iterations < NEWTON_MAX_ITER {
        let mut jac = DMatrix::zeros(n, n);
        for (c, &j) in others.iter().enumerate() {
            let q0 = q[j];
            q[j] = q0 + H_NEWTON;
            let fp = kane.forcing(0.0, q, u).clone();
            q[j] = q0 - H_NEWTON;
            let fm = kane.forcing(0.0, q, u).clone();
            q[j] = q0;
            jac.set_column(c, &((fp - fm) / (2.0 * H_NEWTON)));
        }
        jac.set_column(n - 1, g_s);
        // The pseudo-inverse takes the minimum-norm step along neutral directions (a
        // pendulum at Ω = 0, a second free root) instead of failing.
        let svd = bounded::svd(jac, true, true)?;
        let eps = 1e-13 * svd.singular_values.max();
        let step = svd.solve(&(-&r), eps).map_err(|e| LinearError::Invalid(format!("internal: {e}")))?;
        for (c, &j) in others.iter().enumerate() {
            q[j] += step[c];
        }
        t_m += step[n - 1];
        iterations += 1;
        let small = others.iter().enumerate().all(|(c, _)| step[c].abs() <= 1e-15)
            && step[n - 1].abs() <= 1e-15 * (1.0 + t_m.abs());
        (r, residual) = accel(kane, q, t_m)?;
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
    Ok((t_m, residual, iterations))
}

/// The order-one generalized force of gravity and world-frame point forces on the linearised
/// mechanism (zero without them), and whether any acts.
fn gravity_forcing(
    mech: &Mechanism,
    model_mech: &Mechanism,
    rotation: &[f64],
    s: usize,
    q: &[f64],
    u: &[f64],
) -> LinResult<(DVector<C64>, bool)> {
    let n = q.len();
    // Gravity forces the rotation at order 1 (its mean is zero, so the equilibrium above,
    // found without it, is the one to expand about).
    let gravity_loaded = mech.loads.needs_world_orientation();
    if gravity_loaded && rotation.iter().enumerate().any(|(k, &z)| k != s && z != 0.0) {
        return Err(LinearError::WorldOrientation {
            mechanism: mech.name.clone(),
            detail: "joints geared or meshed to the spin joint turn at their own rates, so gravity forces \
                         several orders"
                .into(),
        });
    }
    let gravity_force = if gravity_loaded {
        let mut loaded = model_mech.clone();
        loaded.loads.gravity = mech.loads.gravity;
        loaded.loads.point_forces.clone_from(&mech.loads.point_forces);
        gravity::order_one_force(&loaded, model_mech, q, u, s)?
    } else {
        DVector::from_element(n, C64::new(0.0, 0.0))
    };
    Ok((gravity_force, gravity_loaded))
}

impl LinearModel {
    /// Linearises `mech` about a steady spin of joint `spin_joint` at `omega_rad_s`, the other
    /// coordinates at the relative equilibrium found by Newton from `guess` (all n coordinates;
    /// the spin entry is ignored; default all 0).
    pub fn new(mech: &Mechanism, spin_joint: &str, omega_rad_s: f64, guess: Option<&[f64]>) -> LinResult<Self> {
        let n = mech.ndof();
        let (sj, s) = spin_of(mech, spin_joint)?;
        let rotation = mech.rigid_rotation(sj).map_err(LinearError::Invalid)?;
        if !omega_rad_s.is_finite() {
            return Err(LinearError::Invalid(format!("spin speed must be finite, got {omega_rad_s} rad/s")));
        }
        let mut q = match guess {
            Some(g) if g.len() != n => return Err(LinearError::Length { what: "guess", got: g.len(), expected: n }),
            Some(g) => g.to_vec(),
            None => vec![0.0; n],
        };
        q[s] = 0.0;
        let prepared = prepare(mech, sj);
        let mut kane = Kane::new(&prepared)?;
        let w_inv = prepared.speeds.w_inverse_matrix(&prepared.speed_parents());
        let parents = prepared.speed_parents();
        let qdot0: Vec<f64> = rotation.iter().map(|z| omega_rad_s * z).collect();
        let mut u = vec![0.0; n];
        prepared.speeds.u_from_qdot(&parents, &qdot0, &mut u);
        let g_s: DVector<f64> = w_inv.row(s).transpose();
        let (t_m, residual, iterations) = relative_equilibrium(&mut kane, mech, &mut q, &u, &g_s, (s, omega_rad_s))?;
        kane.set_joint_torque(sj, Excitation::constant(t_m));
        let mass = kane.mass_matrix(&q).clone();
        let (f_q, f_u) = forcing_jacobians(&mut kane, &q, &u);
        let mut kane_free = Kane::new(&undamped(&prepared))?;
        let (_, f_u_undamped) = forcing_jacobians(&mut kane_free, &q, &u);
        let partials = (0..mech.bodies.len()).map(|b| kane.partial_velocities(&q, b)).collect();
        let mut model_mech = prepared;
        model_mech
            .loads
            .joint_torques
            .push(crate::model::loads::JointTorque { joint: sj, excitation: Excitation::constant(t_m) });
        let (gravity_force, gravity_loaded) = gravity_forcing(mech, &model_mech, &rotation, s, &q, &u)?;
        Ok(LinearModel {
            mech: model_mech,
            op: OperatingPoint {
                spin_joint: sj,
                spin_coordinate: s,
                rotation,
                omega: omega_rad_s,
                q,
                u,
                mean_spin_torque: t_m,
                residual,
                iterations,
            },
            mass,
            f_q,
            f_u,
            f_u_undamped,
            w_inv,
            gravity_force,
            gravity_loaded,
            partials,
        })
    }

    /// The mechanism as linearised: applied torques frozen at their means, the spin joint driven
    /// by the mean torque T_m, without gravity and world-frame forces (they are
    /// [`LinearModel::gravity_force`]).
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
    /// the parent): `g_r = ∂q̇_joint/∂u_r`; zero for a welded joint (it has no coordinate).
    pub fn generalized_torque(&self, joint: usize) -> DVector<f64> {
        match self.mech.coordinate(joint) {
            Some(k) => self.w_inv.row(k).transpose(),
            // A rigidly geared joint's unit torque reaches its driving coordinate times the ratio.
            None => match self.mech.follow_map()[joint] {
                Some(f) => f.factor * self.w_inv.row(f.coordinate).transpose(),
                None => DVector::zeros(self.ndof()),
            },
        }
    }

    /// The row c of the absolute angular velocity of body `body`, `ω_body = c·u` (the sum of the
    /// rates of the rotating joints on its path, [`Mechanism::rotation_coordinates`]).
    pub fn angular_velocity_row(&self, body: usize) -> DVector<f64> {
        let mut c = DVector::zeros(self.ndof());
        for (k, factor) in self.mech.rotation_rates(body) {
            c += factor * self.w_inv.row(k).transpose();
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
}

/// The same mechanism with another choice of generalized speeds. No result of this module (eigen-
/// orders, shapes in q, responses of body accelerations) depends on that choice; this is for
/// checking exactly that.
pub fn with_speeds(mech: &Mechanism, speeds: Speeds) -> Mechanism {
    Mechanism { speeds, ..mech.clone() }
}
