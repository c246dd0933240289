//! The joints' nonlinear couplings ([`crate::model::coupling`]: staged springs, friction, end
//! stops) as generalized forces, added after whichever form evaluated M and F, with their exact
//! local derivatives for the Jacobians.
//!
//! A coupling's torque τ(q_k, q̇_k) acts +τ on the child and −τ on the parent, so its generalized
//! force is τ for the joint rate q̇_k, and with absolute angular velocities (q̇_k = u_k − u_p)
//! +τ in row k and −τ in row p (Bᵀ applied to the joint-rate force, as for a spring).

use super::{Model, Workspace};

/// The couplings' suspension made by [`super::Kane::suspend_couplings`], to be handed back to
/// [`super::Kane::restore_couplings`].
#[derive(Debug)]
pub struct CouplingsSuspended {
    /// Whether they were suspended already (a nested suspension restores to suspended).
    pub(super) was_suspended: bool,
}

impl Model {
    /// The couplings' generalized forces added to F (in the speeds), in the one place every form
    /// goes through (see the module doc).
    #[inline(never)]
    pub(super) fn add_couplings(&self, ws: &mut Workspace, q: &[f64], u: &[f64]) {
        for c in &self.couplings {
            let qd = u[c.coord] - c.parent_speed.map_or(0.0, |p| u[p]);
            let tau = c.law.torque(q[c.coord], qd);
            ws.f[c.coord] += tau;
            if let Some(p) = c.parent_speed {
                ws.f[p] -= tau;
            }
        }
    }

    /// `sign` times the couplings' derivatives of F added to `f_q`, `f_u` (row-major n × n, in
    /// the speeds; −1: of the residual `M u̇ − F`): `∂F/∂q` gets ∂τ/∂q (the local stiffness, with
    /// sign), `∂F/∂u` gets ∂τ/∂q̇ mapped by `q̇_k = u_k − u_p`.
    pub(super) fn coupling_jacobians(&self, q: &[f64], u: &[f64], f_q: &mut [f64], f_u: &mut [f64], sign: f64) {
        let n = self.n;
        for c in &self.couplings {
            let k = c.coord;
            let qd = u[k] - c.parent_speed.map_or(0.0, |p| u[p]);
            let (_, dq, dv) = c.law.torque_and_slopes(q[k], qd);
            let (dq, dv) = (sign * dq, sign * dv);
            f_q[k * n + k] += dq;
            f_u[k * n + k] += dv;
            if let Some(p) = c.parent_speed {
                f_q[p * n + k] -= dq;
                f_u[k * n + p] -= dv;
                f_u[p * n + k] -= dv;
                f_u[p * n + p] += dv;
            }
        }
    }
}
