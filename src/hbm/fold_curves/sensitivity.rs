//! The derivative of a singular point (a fold, a loss of unison, a period doubling) along a
//! third parameter, by the implicit function theorem on its minimally augmented system
//! `R̂(x, λ, p) = 0, g(x, λ, p) = 0` at fixed σ (the plane's second parameter):
//!
//! `[[J, ∂R̂/∂λ], [∂g/∂x, ∂g/∂λ]] [dx/dp; dλ/dp] = −[∂R̂/∂p; ∂g/∂p]`,
//!
//! with `∂g/∂p = −wᵀ (∂J/∂p) v` by central differences of J between p ± h (as for the curve's
//! own derivatives, see the room's docs). The matrix is regular at a simple fold whenever
//! `wᵀ ∂R̂/∂λ ≠ 0` (the branch turns there), and at a singular block whenever g crosses zero
//! along the branch. At a fold of the whole Jacobian, wᵀJ = 0 makes the first block-row alone give
//! `dλ/dp = −wᵀ ∂R̂/∂p / wᵀ ∂R̂/∂λ`: ∂g/∂p moves only the state's derivative there.

use super::plane::{FoldCurvePoint, FoldPlane, Singularity};
use crate::hbm::balance::{At, Hbm, HbmError, Parameter};
use crate::hbm::numerics::DenseLu;
use crate::hbm::sensitivity::{DESIGN_STEP, Direction, StateSensitivity};
use nalgebra::{DMatrix, DVector};

/// The derivative of a singular point along one [`Direction`], per unit of its parameter.
#[derive(Debug, Clone, PartialEq)]
pub struct SingularSensitivity {
    /// d/dp of the point's first parameter in its own unit: the order n on an order plane, the
    /// mean speed Ω (rad/s) on a speed plane, the torque scale s on a torque plane.
    pub parameter: f64,
    /// d/dp of the state at the point as it moves with p (the singular point followed, not a
    /// state at fixed λ).
    pub state: StateSensitivity,
}

impl Hbm {
    /// The derivatives of the singular point `point` of `test` in `plane` (as returned by
    /// [`Hbm::fold_at`] or [`Hbm::singular_at`] on this problem, at its own second parameter)
    /// along each of `directions`. A direction may not be the plane's own first parameter.
    ///
    /// # Errors
    /// A direction along the plane's first parameter, a point of another problem, a singular
    /// augmented matrix (not a simple singular point: a cusp, where the fold's order has no
    /// derivative in a third parameter, or a point where the tested matrix is singular along
    /// the branch without crossing), a family that fails to build, or a non-finite result.
    pub fn singular_sensitivities(
        &mut self,
        plane: FoldPlane,
        test: Singularity,
        point: &FoldCurvePoint,
        directions: &[Direction<'_>],
    ) -> Result<Vec<SingularSensitivity>, HbmError> {
        let at = At { order: point.order, omega: point.omega, scale: point.scale };
        let x = self.differentiable(&point.solution)?;
        let m = x.len();
        let mut walk = self.walk(plane, test, None, &x, &at, None)?;
        walk.central = true;
        let aug = self.augmented(&x, &at, None, &mut walk)?;
        let (param, per_unit) = (walk.plane.param(), walk.plane.per_unit());
        // v and w in the whole space (the augmented system keeps them on the tested block).
        let (mut v, mut w) = (DVector::zeros(m), DVector::zeros(m));
        for (a, &i) in walk.block.iter().enumerate() {
            (v[i], w[i]) = (aug.v[a], aug.w[a]);
        }
        let mut mat = DMatrix::zeros(m + 1, m + 1);
        mat.view_mut((0, 0), (m, m)).copy_from(&aug.j);
        mat.view_mut((0, m), (m, 1)).copy_from(&aug.rl);
        mat.view_mut((m, 0), (1, m)).copy_from(&aug.gx.transpose());
        mat[(m, m)] = aug.gl;
        let lu = mat.lu();
        let (spin, nb, t_scale) = (self.spin, self.nb, self.t_scale);
        let mut out = Vec::with_capacity(directions.len());
        for d in directions {
            across(d, param)?;
            let (mut rp, jv) = self.moved_residual_and_jacobian(&x, &at, d, param, &v)?;
            for &i in &walk.pinned {
                rp[i] = 0.0;
            }
            let mut rhs = DVector::zeros(m + 1);
            rhs.rows_mut(0, m).copy_from(&(-rp));
            rhs[m] = w.dot(&jv);
            let z = lu.solve(&rhs).ok_or(HbmError::Singular { order: at.order })?;
            if z.iter().any(|v| !v.is_finite()) {
                return Err(HbmError::NonFinite { order: at.order });
            }
            let dlambda = z[m];
            let moved = dlambda * per_unit;
            let own_rate = match param {
                Parameter::Order => moved / at.order,
                Parameter::Speed { .. } => moved / at.omega,
                Parameter::TorqueScale { .. } => 0.0,
            };
            let mut coefficients: Vec<f64> = z.rows(0, m).iter().copied().collect();
            let mean_torque = coefficients[spin * nb] * t_scale;
            coefficients[spin * nb] = 0.0;
            let state = StateSensitivity {
                coefficients,
                mean_torque,
                base_frequency_rate: d.base_frequency_rate(&at) + own_rate,
            };
            out.push(SingularSensitivity { parameter: moved, state });
        }
        Ok(out)
    }

    /// The derivative of a fold's first parameter alone (n, Ω in rad/s, or s, per unit of each
    /// direction's parameter) by `dλ/dp = −wᵀ∂R̂/∂p / wᵀ∂R̂/∂λ`, w the left null vector of J at
    /// the fold (`point`, as from [`Hbm::fold_at`] on this problem): one Jacobian, one
    /// factorisation and its transposed solves, then ∂R̂/∂p per direction; no second
    /// derivatives, which only the state's motion along the fold needs
    /// ([`Hbm::singular_sensitivities`] gives both).
    ///
    /// # Errors
    /// As [`Hbm::singular_sensitivities`]; also a branch that does not turn at the point
    /// (wᵀ∂R̂/∂λ = 0, a cusp or a branch point, where the fold has no such derivative).
    pub fn fold_sensitivities(
        &mut self,
        plane: FoldPlane,
        point: &FoldCurvePoint,
        directions: &[Direction<'_>],
    ) -> Result<Vec<f64>, HbmError> {
        let at = At { order: point.order, omega: point.omega, scale: point.scale };
        let x = self.differentiable(&point.solution)?;
        let param = self.plane(plane).param();
        self.assemble(&x, &at, Some(param));
        let rl = self.gp.clone();
        let w = left_null_vector(&self.jac).ok_or(HbmError::Singular { order: at.order })?;
        let turn = w.dot(&rl);
        if !(turn.is_finite() && turn.abs() > 1e-12 * w.norm() * rl.norm()) {
            return Err(HbmError::Invalid(format!(
                "the branch does not turn at the fold near n = {} (wᵀ∂R̂/∂λ = {turn:e}): a cusp or a branch point",
                at.order
            )));
        }
        directions
            .iter()
            .map(|d| {
                across(d, param)?;
                let dl = -w.dot(&self.residual_derivative(&x, &at, d)?) / turn;
                if dl.is_finite() { Ok(dl) } else { Err(HbmError::NonFinite { order: at.order }) }
            })
            .collect()
    }

    /// ∂R̂/∂p and `(∂J/∂p) v` at x and `at` along `direction`, with J the Jacobian whose
    /// companion derivative is `param`'s: the residual's derivative exact for an operating
    /// parameter, both by central differences between p ± h otherwise (h = [`DESIGN_STEP`]
    /// times the family's reference, or times the operating parameter's value).
    fn moved_residual_and_jacobian(
        &mut self,
        x: &[f64],
        at: &At,
        direction: &Direction<'_>,
        param: Parameter,
        v: &DVector<f64>,
    ) -> Result<(DVector<f64>, DVector<f64>), HbmError> {
        match *direction {
            Direction::Operating(p) => {
                let (value, shift): (f64, fn(At, f64) -> At) = match p {
                    Parameter::Order => (at.order, |a, h| At { order: a.order + h, ..a }),
                    Parameter::Speed { .. } => (at.omega, |a, h| At { omega: a.omega + h, ..a }),
                    Parameter::TorqueScale { .. } => (at.scale, |a, h| At { scale: a.scale + h, ..a }),
                };
                let h = DESIGN_STEP * value.abs().max(f64::MIN_POSITIVE);
                self.assemble(x, &shift(*at, h), Some(param));
                let up = &self.jac * v;
                self.assemble(x, &shift(*at, -h), Some(param));
                let jv = (up - &self.jac * v) / (2.0 * h);
                let rp = self.residual_derivative(x, at, direction)?;
                Ok((rp, jv))
            }
            Direction::Design(point) => {
                let (rp, jv) = point.differences(x, at, Some((param, v)))?;
                Ok((rp, jv.unwrap_or_else(|| DVector::zeros(x.len()))))
            }
        }
    }
}

/// The left null vector of a (numerically) singular J, unit length: two steps of inverse
/// iteration on Jᵀ from a flat vector (at a located fold J's smallest singular value is ~1e-10
/// of the next, so each step removes that much of the other directions), or the SVD's left
/// singular vector of the smallest singular value where an LU solve is not finite.
fn left_null_vector(j: &DMatrix<f64>) -> Option<DVector<f64>> {
    let m = j.nrows();
    let lu = DenseLu::new(j);
    let mut w = DVector::from_element(m, 1.0 / (m as f64).sqrt());
    for _ in 0..2 {
        match lu.solve_transposed(&w) {
            Some(next) if next.iter().all(|v| v.is_finite()) && next.norm() > 0.0 => w = next.normalize(),
            _ => {
                let svd = j.clone().svd(true, false);
                let k = svd.singular_values.imin();
                return svd.u.map(|u| u.column(k).clone_owned());
            }
        }
    }
    Some(w)
}

/// Refuses a direction along the plane's own first parameter `param`: the singular point is a
/// function of the other parameters, and has no derivative along the one it is located in.
fn across(direction: &Direction<'_>, param: Parameter) -> Result<(), HbmError> {
    match direction {
        Direction::Operating(p) if std::mem::discriminant(p) == std::mem::discriminant(&param) => {
            Err(HbmError::Invalid(
                "a singular point's sensitivity along its plane's own first parameter is undefined".into(),
            ))
        }
        _ => Ok(()),
    }
}
