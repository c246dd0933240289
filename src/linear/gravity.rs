//! The gravity-forced linear response: gravity (and any world-frame point force) acting on the
//! mechanism at its nominal steady rotation, passed through the same linear transfer as the
//! engine orders (eq. 22 with the gravity force in place of `â`).
//!
//! # Why order 1, exactly
//! At the nominal motion `q = q⁰ + ψ e_s`, `ψ = Ωt`, every body of the spinning subtree is the
//! body at ψ = 0 turned rigidly by ψ, and its partial velocities in the world are the ψ = 0 ones
//! turned by ψ (relative joint rates and absolute angular velocities do not change under a rigid
//! rotation). The generalized force of a constant world force `f` at a point with partial
//! velocity `v_r` is `f·R(ψ)v_r = cos ψ (f·v_r) + sin ψ (f·J v_r)`, J the quarter turn: a pure
//! harmonic of order 1 in the rotor angle, `F_g(t) = a cos Ωt + b sin Ωt = Re(F̂_g e^{iΩt})`,
//! `F̂_g = a − i b`. Its mean is zero, so the relative equilibrium and the mean torque are those
//! without gravity. [`order_one_force`] takes `a` and `b` from the engine (the forcing with
//! and without these loads at ψ = 0 and π/2) and checks the harmonic form at six more angles.
//! A loaded body that does not turn with the spin joint (its weight is a static load, and may
//! give a first-order stiffness, as for a pendulum hung from the ground) or turns at another rate
//! (a gear) breaks the argument: the model is refused rather than given a wrong forcing.
//!
//! # What is neglected
//! Gravity also acts on the deflections: its generalized force depends on `q*` as well, a
//! stiffness `∂F_g/∂q` that turns at order 1 (a parametric term `F_g,q(Ωt) q*`). That term is a
//! product of two small quantities (the gravity ratio `g/(r Ω²)` and the deflection), second
//! order, and is left out: the linear gravity response is exact to first order in gravity and in
//! the torque together. Its size is measured against harmonic balance with gravity in
//! `tests/it/gravity_linear.rs` (the difference falls about as g², as a second-order term should).
//! The parametric term would also shift eigen-orders at second order; the modes and Campbell
//! diagram are those of the steady rotation.
//!
//! # Spin free or held
//! With the spin free the response solves the full 2n state, as the torque response does; with
//! the spin held (speed prescribed) the spin angle and speed are removed and the dropped row is
//! the reaction torque that holds the speed against gravity's order-1 torque.

use super::{C64, LinResult, LinearError, LinearModel, Spin};
use crate::kane::Kane;
use crate::model::mechanism::Mechanism;
use nalgebra::DVector;
use std::f64::consts::FRAC_PI_2;

/// Spin angles (rad) at which the order-1 form is checked: irregular, so that no other harmonic
/// (a gear's order, a static load) can fit the two samples and these by chance.
const CHECK_ANGLES: [f64; 6] = [0.7, 1.9, 2.6, 3.7, 4.9, 5.8];
/// Accepted misfit of the order-1 form, relative to the size of the forcing (rounding of the
/// difference of two forcings that hold the centrifugal terms is ≈ 1e-15 of them).
const ORDER_ONE_RTOL: f64 = 1e-9;
/// A centre of mass whose partial velocities are all below this (m per rad) sits on a fixed
/// axis: its weight does no work and is not a load of the motion.
const LEVER_FLOOR_M: f64 = 1e-12;
/// The lever arm, m, that turns the loads' size into the floor of the forcing size (a balanced
/// mechanism's order-1 force is rounding noise).
const FLOOR_ARM_M: f64 = 1.0;

/// The complex amplitude `F̂_g` (n entries, in the rows of the speeds u, N·m or N) of the
/// generalized force of `loaded`'s gravity and world-frame forces at the nominal rotation of
/// `plain` (the same mechanism without them) through `(q⁰, u⁰)` with spin coordinate `s`:
/// `F_g(Ωt) = Re(F̂_g e^{iΩt})` with the spin angle 0 at t = 0. Errors with
/// [`LinearError::WorldOrientation`] when the force is not of that form.
pub(super) fn order_one_force(
    loaded: &Mechanism,
    plain: &Mechanism,
    q0: &[f64],
    u0: &[f64],
    s: usize,
) -> LinResult<DVector<C64>> {
    let mut with = Kane::new(loaded)?;
    let mut without = Kane::new(plain)?;
    // Every body the loads act on must turn with the spin joint (at ±Ω: a rigid turn of its
    // partial velocities by ±ψ). Anything else (a body hung from the ground, a gear at another
    // ratio) makes its weight a static load or another order, and the linearisation without
    // gravity would miss a first-order stiffness; the sampled check below would not see a
    // static load that happens to vanish at the operating point.
    let world = crate::model::loads::ForceFrame::World;
    for (b, body) in loaded.bodies.iter().enumerate() {
        let weighed = loaded.loads.gravity != crate::model::math::Vec2::zeros()
            && body.inertia.mass > 0.0
            && with.partial_velocities(q0, b).0.iter().any(|v| v.norm() > LEVER_FLOOR_M);
        let pushed = loaded.loads.point_forces.iter().any(|p| p.body == b && p.frame == world);
        if !(weighed || pushed) {
            continue;
        }
        let rate: f64 = loaded.rotation_rates(b).iter().filter(|(k, _)| *k == s).map(|(_, f)| f).sum();
        if (rate.abs() - 1.0).abs() > 1e-12 {
            return Err(LinearError::WorldOrientation {
                mechanism: loaded.name.clone(),
                detail: format!(
                    "body `{}` carries {} but turns at {} times the spin rate",
                    body.name,
                    if weighed { "weight" } else { "a world-frame force" },
                    rate + 0.0 // no "-0"
                ),
            });
        }
    }
    let mut q = q0.to_vec();
    let mut size = 0.0f64;
    let mut at = |psi: f64, size: &mut f64| -> DVector<f64> {
        q[s] = q0[s] + psi;
        let f0 = without.forcing(0.0, &q, u0).clone();
        let d = with.forcing(0.0, &q, u0).clone() - &f0;
        *size = size.max(f0.amax()).max(d.amax());
        d
    };
    let a = at(0.0, &mut size);
    let b = at(FRAC_PI_2, &mut size);
    let mut misfit = 0.0f64;
    let mut worst = 0.0;
    for psi in CHECK_ANGLES {
        let d = at(psi, &mut size);
        let e = (d - &a * psi.cos() - &b * psi.sin()).amax();
        if e.is_nan() || e > misfit {
            (misfit, worst) = (e, psi);
        }
    }
    // A floor for a balanced mechanism, whose order-1 force is zero up to rounding: the loads'
    // own size, the weights and world forces acting at 1 m.
    let loads = loaded.loads.gravity.norm() * loaded.bodies.iter().map(|b| b.inertia.mass).sum::<f64>()
        + loaded.loads.point_forces.iter().map(|p| p.force.norm()).sum::<f64>();
    // NaN must fail too.
    if misfit.is_nan() || misfit > ORDER_ONE_RTOL * size.max(loads * FLOOR_ARM_M) {
        return Err(LinearError::WorldOrientation {
            mechanism: loaded.name.clone(),
            detail: format!(
                "at spin angle {worst} rad its generalized force differs from the order-1 harmonic through its values \
                 at 0 and π/2 by {misfit:e} (forcing size {size:e}): a loaded body does not turn with the spin joint"
            ),
        });
    }
    Ok(DVector::from_fn(a.len(), |i, _| C64::new(a[i], -b[i])))
}

impl LinearModel {
    /// True when the mechanism has gravity or a world-frame force (its [`LinearModel::gravity_force`]
    /// is then the order-1 forcing they give; it may still be zero, e.g. weight on the axis).
    pub fn has_gravity(&self) -> bool {
        self.gravity_loaded
    }

    /// The complex amplitudes `x̂ = [q̂; û]` (2n; rad and rad/s, m and m/s for slides) of the
    /// steady order-1 response to gravity and the world-frame forces (see the module docs),
    /// `x(t) = Re(x̂ e^{iΩt})`, spin angle 0 at t = 0; with the spin held, the spin angle and
    /// speed entries are 0. Zero without gravity. Errors when `iΩM + A` is singular (Ω = 0 with
    /// the spin free, or an undamped mode at order 1).
    pub fn gravity_state_response(&self, spin: Spin) -> LinResult<DVector<C64>> {
        self.forced_state(spin, 1.0, &self.gravity_force)
    }

    /// Complex amplitude of body `body`'s angular acceleration at order 1 under gravity, spin
    /// free, rad/s²: `α̂ = iΩ c·û` of [`LinearModel::gravity_state_response`].
    pub fn gravity_acceleration(&self, body: usize) -> LinResult<C64> {
        let n = self.ndof();
        let x = self.gravity_state_response(Spin::Free)?;
        let c = self.angular_velocity_row(body);
        let om: C64 = (0..n).map(|r| x[n + r] * c[r]).sum();
        Ok(C64::new(0.0, self.op.omega) * om)
    }
}
