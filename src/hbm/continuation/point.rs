//! A state of the continuation ([`Cursor`]) and the branch point made of it, with the step
//! below which a stalled solve counts as converged while locating an event.

use super::branch::BranchPoint;
use crate::hbm::balance::{Hbm, HbmError, Parameter, Setup};
use crate::hbm::series::HbmSolution;
use nalgebra::DVector;

/// Unit tangent and state carried along the branch.
pub(in crate::hbm) struct Cursor {
    pub(in crate::hbm) y: DVector<f64>,
    pub(in crate::hbm) t: DVector<f64>,
}

impl Hbm {
    /// The branch point at the continuation state y (its tangent, arclength `s` and corrector
    /// iterations given), with its Floquet stability when `stability`; the pairs' senses are
    /// left in the problem's buffer.
    pub(super) fn branch_point(
        &mut self,
        su: &Setup,
        y: &DVector<f64>,
        tangent: Option<&DVector<f64>>,
        s: f64,
        iterations: usize,
        stability: bool,
    ) -> Result<BranchPoint, HbmError> {
        let m = self.unknowns();
        let slope = tangent.map_or(0.0, |t| t[m]);
        let (mut d_coefficients, mut d_mean_torque) = (Vec::new(), 0.0);
        if let Some(t) = tangent {
            d_coefficients = su.x_of(t.as_slice(), m);
            let gauge = self.spin * self.nb;
            d_mean_torque = d_coefficients[gauge] * self.t_scale;
            d_coefficients[gauge] = 0.0;
        }
        let x = su.x_of(y.as_slice(), m);
        let mut sol = self.solution_from(&x, &su.at(y[m]), iterations);
        self.pair_senses.clear();
        if stability && self.opts.stability_samples > 0 {
            sol.stability = Some(self.stability(&sol)?);
        }
        Ok(BranchPoint {
            order: sol.order,
            parameter: y[m] * su.p_ref,
            arclength: s,
            slope,
            order_slope: if su.param == Parameter::Order { slope } else { 0.0 },
            accel_main: sol.order_acceleration(self.spin, 1.0),
            accel_second: sol.order_acceleration(self.spin, 2.0),
            pendulum_amplitude: sol.max_peak_amplitude(),
            stable: sol.stability.as_ref().map(|st| st.stable),
            solution: sol,
            d_coefficients,
            d_mean_torque,
            d_parameter: slope * su.p_ref,
        })
    }

    pub(super) fn y_of(&self, su: &Setup, sol: &HbmSolution) -> DVector<f64> {
        let m = self.unknowns();
        let x = self.unknowns_from(Some(sol));
        let mut y = DVector::from_fn(m + 1, |i, _| if i < m { x[i] * su.w(i) } else { 0.0 });
        y[m] = su.lambda(sol);
        y
    }

    /// The step below which a Newton solve that stopped contracting is taken as converged while
    /// locating an event ([`Hbm::solve_within`]): 1000 times the tolerance. Beside a branch
    /// point the steps stall at 1e-10–1e-9 (a tolerance of 1e-10); a state that close decides a
    /// count of multipliers or the sign of a determinant as well as a converged one, where a
    /// failed solve used to end the bisection with the bracket as wide as it then was.
    pub(super) fn stall_floor(&self) -> f64 {
        1e3 * self.opts.tol
    }
}
