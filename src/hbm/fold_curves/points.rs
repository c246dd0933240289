//! One singular point of the augmented system: a fold (or a loss of unison, a period doubling)
//! at a given value of one parameter, by Newton's method on `R̂ = 0, g = 0` with the other
//! free; and the signs of the tested matrices' determinants along a branch.

use super::augmented::Lu;
use super::augmented::{Walk, settled};
use super::plane::{FoldCurvePoint, FoldPlane, Singularity};
use crate::hbm::balance::{At, Hbm, HbmError, Parameter};
use crate::hbm::balance::{MechanismFamily, on_family, problem};
use crate::hbm::series::HbmSolution;
use nalgebra::{DMatrix, DVector};

impl Hbm {
    /// Newton's method on `R̂ = 0, g = 0` with one of (λ, σ) free: λ when `free_lambda`, else σ.
    pub(super) fn fold_solve(
        &mut self,
        walk: &mut Walk,
        x: &mut [f64],
        (lambda, sigma): (&mut f64, &mut f64),
        free_lambda: bool,
    ) -> Result<usize, HbmError> {
        let m = self.unknowns();
        let mut previous = f64::INFINITY;
        for it in 1..=self.opts.max_iter {
            let (at, p) = walk.at(*lambda, *sigma);
            let aug = self.augmented(x, &at, p, walk)?;
            let mut mat = DMatrix::zeros(m + 1, m + 1);
            mat.view_mut((0, 0), (m, m)).copy_from(&aug.j);
            let (col, corner) = if free_lambda { (&aug.rl, aug.gl) } else { (&aug.rs, aug.gs) };
            mat.view_mut((0, m), (m, 1)).copy_from(col);
            mat[(m, m)] = corner;
            mat.view_mut((m, 0), (1, m)).copy_from(&aug.gx.transpose());
            let mut rhs = DVector::zeros(m + 1);
            rhs.rows_mut(0, m).copy_from(&aug.r);
            rhs[m] = aug.g;
            let d = Lu::new(&mat).solve(&rhs).ok_or(HbmError::Singular { order: at.order })?;
            let step = d.amax();
            if !step.is_finite() {
                return Err(HbmError::NonFinite { order: at.order });
            }
            for (xi, di) in x.iter_mut().zip(d.iter()) {
                *xi -= di;
            }
            if free_lambda {
                *lambda -= d[m];
            } else {
                *sigma -= d[m];
            }
            (walk.b, walk.c) = (aug.w.normalize(), aug.v.normalize());
            if step <= self.opts.tol || settled(step, previous, self.opts.tol) {
                return Ok(it);
            }
            previous = step;
        }
        Err(HbmError::NoConvergence {
            order: walk.at(*lambda, *sigma).0.order,
            iterations: self.opts.max_iter,
            step: f64::NAN,
        })
    }

    /// The fold in `plane` at torque scale `scale` nearest `guess` (a state near a fold of a
    /// branch in the plane's first parameter, e.g. the branch point before one of its
    /// [`Fold`](crate::hbm::Fold)s): Newton's method on `R̂ = 0, g = 0` in (x, n) or (x, Ω).
    pub fn fold_at(&mut self, plane: FoldPlane, scale: f64, guess: &HbmSolution) -> Result<FoldCurvePoint, HbmError> {
        self.singular_at(plane, Singularity::Jacobian, scale, guess)
    }

    /// The singularity tests of the problem's non-unison motions: on the unison problem of
    /// identical absorbers ([`RoutedHbm::hbm_mut`](crate::hbm::RoutedHbm::hbm_mut)), one
    /// [`Singularity::Block`] per identical set, with the set's label; empty on any other
    /// problem, or where a representative's coordinates are not consecutive.
    pub fn unison_loss_tests(&self) -> Vec<(String, Singularity)> {
        self.non_unison
            .iter()
            .filter_map(|nu| {
                let (&first, count) = (nu.coordinates.first()?, nu.coordinates.len());
                let consecutive = nu.coordinates.iter().enumerate().all(|(k, &c)| c == first + k);
                consecutive.then(|| (nu.label.clone(), Singularity::Block { first, count }))
            })
            .collect()
    }

    /// The sign (±1) of the determinant of the matrix `test` keeps singular, at `sol`: between
    /// two states of a branch where it changes, that matrix is singular (for a
    /// [`Singularity::Block`] of the unison problem: unison is lost or regained there). The
    /// sign from J's LU factors (the product of U's diagonal signs and the permutation's), which
    /// neither overflows nor underflows whatever the size; 0 when a pivot is exactly zero.
    pub fn singularity_sign(&mut self, sol: &HbmSolution, test: Singularity) -> f64 {
        self.singularity_signs(sol, &[test])[0]
    }

    /// [`Hbm::singularity_sign`] of each of `tests`, from one Jacobian.
    pub fn singularity_signs(&mut self, sol: &HbmSolution, tests: &[Singularity]) -> Vec<f64> {
        let x = self.unknowns_from(Some(sol));
        let at = At { order: sol.order, omega: sol.omega, scale: sol.torque_scale };
        self.assemble(&x, &at, Some(Parameter::Order));
        tests
            .iter()
            .map(|&test| {
                let block = self.tested(test);
                let mb = block.len();
                let jb = DMatrix::from_fn(mb, mb, |a, b| self.jac[(block[a], block[b])]);
                let lu = jb.lu();
                let u = lu.u();
                let diag: f64 = (0..mb).map(|i| u[(i, i)].signum() * f64::from(u[(i, i)] != 0.0)).product();
                diag * lu.p().determinant::<f64>()
            })
            .collect()
    }

    /// [`Hbm::fold_at`] for the singularity `test` (a loss of unison with [`Singularity::Block`]).
    pub fn singular_at(
        &mut self,
        plane: FoldPlane,
        test: Singularity,
        scale: f64,
        guess: &HbmSolution,
    ) -> Result<FoldCurvePoint, HbmError> {
        self.singular_at_with(plane, None, test, scale, guess)
    }

    /// [`Hbm::singular_at`] with the second parameter `second`: the torque scale s (`family`
    /// None), or the mechanism parameter p of `family` (its unit; `self` is then any problem of
    /// the family, for the layout of the unknowns).
    pub fn singular_at_with(
        &mut self,
        plane: FoldPlane,
        family: Option<&MechanismFamily<'_>>,
        test: Singularity,
        second: f64,
        guess: &HbmSolution,
    ) -> Result<FoldCurvePoint, HbmError> {
        let mut x = self.unknowns_from(Some(guess));
        let scale = family.map_or(second, |f| f.scale);
        let at = match plane {
            FoldPlane::Order => At { order: guess.order, omega: guess.omega, scale },
            FoldPlane::Speed { order } => At { order, omega: guess.omega, scale },
            FoldPlane::Torque { order } => At { order, omega: guess.omega, scale: guess.torque_scale },
        };
        self.singular_solve(plane, family, test, &mut x, at, second, true)
    }

    /// The fold in `plane` at the value `value` of its first parameter (n, or Ω in rad/s)
    /// nearest `guess`, the torque scale free: Newton's method on `R̂ = 0, g = 0` in (x, s).
    pub fn fold_at_value(
        &mut self,
        plane: FoldPlane,
        value: f64,
        guess: &HbmSolution,
    ) -> Result<FoldCurvePoint, HbmError> {
        self.singular_at_value(plane, Singularity::Jacobian, value, guess)
    }

    /// [`Hbm::fold_at_value`] for the singularity `test` (a loss of unison with
    /// [`Singularity::Block`]).
    pub fn singular_at_value(
        &mut self,
        plane: FoldPlane,
        test: Singularity,
        value: f64,
        guess: &HbmSolution,
    ) -> Result<FoldCurvePoint, HbmError> {
        self.singular_at_value_with(plane, None, test, value, guess.torque_scale, guess)
    }

    /// [`Hbm::singular_at_value`] with the second parameter (free, from `second`) the torque
    /// scale (`family` None) or the mechanism parameter p of `family`.
    pub fn singular_at_value_with(
        &mut self,
        plane: FoldPlane,
        family: Option<&MechanismFamily<'_>>,
        test: Singularity,
        value: f64,
        second: f64,
        guess: &HbmSolution,
    ) -> Result<FoldCurvePoint, HbmError> {
        let mut x = self.unknowns_from(Some(guess));
        let scale = family.map_or(second, |f| f.scale);
        let at = match plane {
            FoldPlane::Order => At { order: value, omega: guess.omega, scale },
            FoldPlane::Speed { order } => At { order, omega: value, scale },
            FoldPlane::Torque { order } => At { order, omega: guess.omega, scale: value },
        };
        self.singular_solve(plane, family, test, &mut x, at, second, false)
    }

    /// Newton's method on `R̂ = 0, g = 0` from x at `at` (its first parameter's start) and the
    /// second parameter `second`, the first parameter free when `free_lambda`, else the second.
    #[allow(clippy::too_many_arguments)]
    pub(super) fn singular_solve(
        &mut self,
        plane: FoldPlane,
        family: Option<&MechanismFamily<'_>>,
        test: Singularity,
        x: &mut [f64],
        at: At,
        second: f64,
        free_lambda: bool,
    ) -> Result<FoldCurvePoint, HbmError> {
        let p = family.map(|_| second);
        let at = match family {
            Some(f) => on_family(at, f, second),
            None => at,
        };
        let mut walk = self.walk(plane, test, family, x, &at, p)?;
        let (mut lambda, mut sigma) = (walk.plane.lambda(&at), walk.sigma(second));
        let it = self.fold_solve(&mut walk, x, (&mut lambda, &mut sigma), free_lambda)?;
        let (at, p) = walk.at(lambda, sigma);
        let solution = problem(self, &mut walk.built, family, p)?.solution_from(x, &at, it);
        Ok(walk.point(&at, sigma, 0.0, solution))
    }
}
