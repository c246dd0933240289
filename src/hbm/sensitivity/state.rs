//! The derivative of one periodic state along a parameter (the room's docs): ∂R̂/∂p per
//! [`Direction`], one factorisation of J at the state, a back-solve per direction, and the
//! chain rules from the coefficients to the read-outs ([`StateSensitivity`]).

use crate::hbm::balance::{At, Hbm, HbmError, MechanismFamily, Parameter};
use crate::hbm::series::HbmSolution;
use nalgebra::DVector;
use std::cell::RefCell;

/// Step of a design parameter's central difference of the residual, relative to the family's
/// reference: the difference errs by O(h²) of the residual's third derivative in p and by
/// O(ε/h) of rounding, both near 1e-10 of R̂'s scale at this h.
pub(in crate::hbm) const DESIGN_STEP: f64 = 1e-5;

/// A parameter a sensitivity is taken along.
#[derive(Debug, Clone, Copy)]
pub enum Direction<'a> {
    /// An operating parameter: the order n, the mean speed Ω (rad/s) or the torque scale s;
    /// derivatives per unit of it. The order a `Speed` or `TorqueScale` variant names is not
    /// read: the state's own is used.
    Operating(Parameter),
    /// A design parameter of the mechanism at a [`DesignPoint`]: the problem the sensitivity
    /// is asked of must be the family's at the point's p; derivatives per unit of p.
    Design(&'a DesignPoint),
}

/// A design parameter's value p with the family's problems at p ± h built once (h =
/// 1e-5 times the family's reference): every state of an operating set at this design
/// is differentiated with them, so the builds are paid once per design and parameter, and a
/// state's derivative costs two residuals and a back-solve.
#[derive(Debug)]
pub struct DesignPoint {
    /// The parameter's value, in the family's unit.
    pub p: f64,
    /// The difference step, in the family's unit.
    pub h: f64,
    /// Whether p is the mean speed Ω (see [`MechanismFamily::speed`]).
    pub speed: bool,
    /// The problems at p + h and p − h (their buffers change as residuals are assembled).
    problems: RefCell<[Hbm; 2]>,
}

impl DesignPoint {
    /// The family's problems at p ± h.
    ///
    /// # Errors
    /// Whatever building a problem returns, and a non-finite or non-positive reference.
    pub fn new(family: &MechanismFamily<'_>, p: f64) -> Result<Self, HbmError> {
        let h = DESIGN_STEP * family.reference;
        if !(h.is_finite() && h > 0.0 && p.is_finite()) {
            return Err(HbmError::Invalid(format!(
                "a design point needs a finite p and a positive reference, got p = {p}, reference {}",
                family.reference
            )));
        }
        let problems = RefCell::new([(family.build)(p + h)?, (family.build)(p - h)?]);
        Ok(Self { p, h, speed: family.speed, problems })
    }

    /// The residual's and (with `jacobian`) the Jacobian-times-v's central differences at x and
    /// `at` (the problems' own at p ± h: a speed family's Ω moves with p).
    pub(in crate::hbm) fn differences(
        &self,
        x: &[f64],
        at: &At,
        jacobian: Option<(Parameter, &DVector<f64>)>,
    ) -> Result<(DVector<f64>, Option<DVector<f64>>), HbmError> {
        let mut problems = self.problems.borrow_mut();
        let mut side = |k: usize, q: f64| -> Result<(DVector<f64>, Option<DVector<f64>>), HbmError> {
            let hbm = &mut problems[k];
            if hbm.unknowns() != x.len() {
                return Err(HbmError::Invalid(format!(
                    "the family's problem at p = {q} has {} unknowns, the state {}",
                    hbm.unknowns(),
                    x.len()
                )));
            }
            let at = if self.speed { At { omega: q, ..*at } } else { *at };
            hbm.assemble(x, &at, jacobian.map(|(param, _)| param));
            Ok((hbm.rhat.clone(), jacobian.map(|(_, v)| &hbm.jac * v)))
        };
        let ((r_up, j_up), (r_down, j_down)) = (side(0, self.p + self.h)?, side(1, self.p - self.h)?);
        let per = 1.0 / (2.0 * self.h);
        Ok(((r_up - r_down) * per, j_up.zip(j_down).map(|(u, d)| (u - d) * per)))
    }
}

impl Direction<'_> {
    /// `(dω₀/dp) / ω₀`: ω₀ = ratio·n·Ω moves with the order and the mean speed only.
    pub(in crate::hbm) fn base_frequency_rate(&self, at: &At) -> f64 {
        match self {
            Direction::Operating(Parameter::Order) => 1.0 / at.order,
            Direction::Operating(Parameter::Speed { .. }) => 1.0 / at.omega,
            Direction::Design(point) if point.speed => 1.0 / at.omega,
            _ => 0.0,
        }
    }
}

/// The derivative of a periodic state along one [`Direction`], per unit of its parameter.
#[derive(Debug, Clone, PartialEq)]
pub struct StateSensitivity {
    /// d/dp of every Fourier coefficient, in the layout of
    /// [`HbmSolution::coefficients`](crate::hbm::HbmSolution::coefficients) (the spin
    /// coordinate's mean, the gauge, stays 0), rad (m for a slide) per unit p.
    pub coefficients: Vec<f64>,
    /// d/dp of the mean torque that sustains the mean speed, N·m per unit p.
    pub mean_torque: f64,
    /// `(dω₀/dp) / ω₀`, the relative rate of the base frequency, per unit p: 1/n along the
    /// order, 1/Ω along the mean speed, 0 along the torque scale and a design parameter.
    pub base_frequency_rate: f64,
}

impl StateSensitivity {
    /// The derivatives `(da_kh/dp, db_kh/dp)` of harmonic h of coordinate k (as
    /// [`HbmSolution::coefficient`]).
    pub fn coefficient(&self, sol: &HbmSolution, k: usize, h: usize) -> (f64, f64) {
        let nb = sol.nb();
        let c = &self.coefficients[k * nb..(k + 1) * nb];
        match h {
            0 => (c[0], 0.0),
            h if h <= sol.harmonics => (c[2 * h - 1], c[2 * h]),
            _ => (0.0, 0.0),
        }
    }

    /// d/dp of [`HbmSolution::amplitude`] `(a² + b²)^½` of harmonic h of coordinate k, rad per
    /// unit p. At a zero amplitude, where the amplitude has no derivative, the rate at which it
    /// grows, `(ȧ² + ḃ²)^½`.
    pub fn amplitude(&self, sol: &HbmSolution, k: usize, h: usize) -> f64 {
        let ((a, b), (da, db)) = (sol.coefficient(k, h), self.coefficient(sol, k, h));
        if h == 0 {
            return da * a.signum();
        }
        let r = a.hypot(b);
        if r > 0.0 { (a * da + b * db) / r } else { da.hypot(db) }
    }

    /// d/dp of [`HbmSolution::acceleration_amplitude`] `(hω₀)²|c_kh|`, rad/s² per unit p.
    pub fn acceleration_amplitude(&self, sol: &HbmSolution, k: usize, h: usize) -> f64 {
        let w = h as f64 * sol.base_frequency;
        w * w * (self.amplitude(sol, k, h) + 2.0 * self.base_frequency_rate * sol.amplitude(k, h))
    }

    /// d/dp of [`HbmSolution::order_acceleration`] at the order `multiple·n`, rad/s² per unit p
    /// (0 where that order is not a harmonic of the state).
    pub fn order_acceleration(&self, sol: &HbmSolution, k: usize, multiple: f64) -> f64 {
        sol.harmonic_of(multiple).map_or(0.0, |h| self.acceleration_amplitude(sol, k, h))
    }

    /// d/dp of [`HbmSolution::peak_amplitude`] `max_τ |p_k(τ) − a_k0|`, rad per unit p: the
    /// derivative of the series at the instant of the peak, where p′ vanishes (so the instant's
    /// own motion adds nothing). Where two instants tie for the peak the derivative is one-sided;
    /// this is the one of the instant the peak search settles on.
    pub fn peak_amplitude(&self, sol: &HbmSolution, k: usize) -> f64 {
        let (_, tau) = sol.peak_at(k);
        let (mut p, mut dp) = (0.0, 0.0);
        for h in 1..=sol.harmonics {
            let (s, c) = (h as f64 * tau).sin_cos();
            let ((a, b), (da, db)) = (sol.coefficient(k, h), self.coefficient(sol, k, h));
            p += a * c + b * s;
            dp += da * c + db * s;
        }
        p.signum() * dp
    }
}

impl Hbm {
    /// The derivatives of the state `sol` (a solution of this problem, at its own order, speed
    /// and torque scale) along each of `directions`: one Jacobian and its factorisation at the
    /// state, then per direction ∂R̂/∂p (the room's docs) and one back-solve.
    ///
    /// # Errors
    /// A state of another problem (another size), a singular Jacobian (the state is a fold or
    /// a branch point: its derivative is infinite there; see the fold-curves room's
    /// `singular_sensitivities`), a family whose problem fails to build at p ± h, or a
    /// non-finite derivative.
    pub fn state_sensitivities(
        &mut self,
        sol: &HbmSolution,
        directions: &[Direction<'_>],
    ) -> Result<Vec<StateSensitivity>, HbmError> {
        let x = self.differentiable(sol)?;
        let at = At { order: sol.order, omega: sol.omega, scale: sol.torque_scale };
        let rates = directions.iter().map(|d| self.residual_derivative(&x, &at, d)).collect::<Result<Vec<_>, _>>()?;
        self.assemble(&x, &at, Some(Parameter::Order));
        let lu = self.factor(None);
        let (spin, nb, t_scale) = (self.spin, self.nb, self.t_scale);
        directions
            .iter()
            .zip(rates)
            .map(|(d, rp)| {
                let dx = lu.solve(&(-rp)).ok_or(HbmError::Singular { order: at.order })?;
                if dx.iter().any(|v| !v.is_finite()) {
                    return Err(HbmError::NonFinite { order: at.order });
                }
                let mut coefficients: Vec<f64> = dx.iter().copied().collect();
                let mean_torque = coefficients[spin * nb] * t_scale;
                coefficients[spin * nb] = 0.0;
                Ok(StateSensitivity { coefficients, mean_torque, base_frequency_rate: d.base_frequency_rate(&at) })
            })
            .collect()
    }

    /// The unknowns of `sol`, refused when it is a state of another problem (another size).
    pub(in crate::hbm) fn differentiable(&self, sol: &HbmSolution) -> Result<Vec<f64>, HbmError> {
        if sol.coefficients.len() != self.unknowns() {
            return Err(HbmError::Invalid(format!(
                "a state of {} unknowns cannot be differentiated on a problem of {}",
                sol.coefficients.len(),
                self.unknowns()
            )));
        }
        Ok(self.unknowns_from(Some(sol)))
    }

    /// ∂R̂/∂p at the unknowns x and `at` along `direction` (see the room's docs): the assembly's
    /// exact one for an operating parameter (which also leaves J at x in the buffers), the
    /// central difference of the residual between the family's problems at p ± h for a design
    /// parameter.
    pub(in crate::hbm) fn residual_derivative(
        &mut self,
        x: &[f64],
        at: &At,
        direction: &Direction<'_>,
    ) -> Result<DVector<f64>, HbmError> {
        match *direction {
            Direction::Operating(param) => {
                self.assemble(x, at, Some(param));
                Ok(self.gp.clone())
            }
            Direction::Design(point) => Ok(point.differences(x, at, None)?.0),
        }
    }
}
