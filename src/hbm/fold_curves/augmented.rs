//! The minimally augmented system of a fold curve (Govaerts 2000, §4.3.2) at one point: R̂, J
//! and ∂R̂/∂λ, ∂R̂/∂σ, the test function g from the bordered solves with J and Jᵀ and its
//! gradient by differences of Jacobians along the null vector, the Newton matrix solved whole or
//! by block elimination on the bordered matrix, and the walk that carries the borders, the
//! tested block and the family's problems from point to point.

use super::plane::{FoldCurvePoint, FoldPlane, Plane, Singularity};
use crate::hbm::balance::{At, Hbm, HbmError, Parameter};
use crate::hbm::balance::{Built, MechanismFamily, on_family, problem};
use crate::hbm::numerics::DenseLu;
use crate::hbm::series::HbmSolution;
use nalgebra::{DMatrix, DVector};

/// Relative step of the differences of the Jacobian along the null vector v (|v| = 1, in rad):
/// central differences err by O(h²) of the third derivatives and by O(ε/h) of rounding.
pub(super) const FD_STEP: f64 = 1e-5;

/// The step of the one-sided differences of the Newton iterations: they err by O(h) of the
/// second derivatives and by O(ε/h) of rounding, balanced near √ε. Newton only needs ∂g/∂x to
/// that accuracy (the residual g is exact, so the converged point is the same); the tangents
/// at turning points of the second parameter take central differences (`Walk::central`).
pub(super) const FD_STEP_ONE_SIDED: f64 = 1e-7;

/// The augmented system's pieces at one point: R̂, J, ∂R̂/∂λ, ∂R̂/∂σ (σ the second parameter:
/// s, or p / reference), and g with its gradient in (x, λ, σ), v and w.
pub(super) struct Augmented {
    pub(super) r: DVector<f64>,
    pub(super) j: DMatrix<f64>,
    pub(super) rl: DVector<f64>,
    pub(super) rs: DVector<f64>,
    pub(super) g: f64,
    pub(super) gx: DVector<f64>,
    pub(super) gl: f64,
    pub(super) gs: f64,
    pub(super) v: DVector<f64>,
    pub(super) w: DVector<f64>,
    /// The LU of the tested block bordered, `[[J_b, b], [cᵀ, 0]]`.
    pub(super) bordered: Lu,
}

/// Whether a Newton iteration whose last two steps (max norm) were `step` and `previous` has
/// settled to `tol` without one more iterate: it contracts at least by step/previous per
/// iterate (≤ 1/2 asked), so the next step, which bounds the error left, is at most
/// step²/previous. The iterate that step verifies costs a whole Jacobian set on a fold curve.
pub(super) fn settled(step: f64, previous: f64, tol: f64) -> bool {
    previous.is_finite() && step <= 0.5 * previous && step * step <= tol * previous
}

/// A converged corrector: the point, its Newton iterations, whether the last iterate's own step
/// was left out as [`settled`], and the last Newton matrix's LU and augmented system (at the
/// iterate one step before y).
pub(super) struct Corrected {
    pub(super) y: DVector<f64>,
    pub(super) iterations: usize,
    pub(super) skipped: bool,
    pub(super) lu: NewtonLu,
    pub(super) aug: Augmented,
}

pub(super) type Lu = DenseLu;

/// The fold curve's Newton matrix `N = [[J, ∂R̂/∂λ, ∂R̂/∂σ], [∂g/∂x, ∂g/∂λ, ∂g/∂σ], [tᵀ]]`
/// ready to solve: factorised whole, or, on a fold curve (the whole J tested, nothing pinned),
/// by block elimination on the bordered matrix `B = [[J, b], [cᵀ, 0]]` whose LU the iterate has
/// already (Govaerts 2000, §3.2, the bordering algorithms): with `φ = cᵀ dx` as an extra unknown
/// and `B [u_k; ξ_k]` solved for the columns ∂R̂/∂λ, ∂R̂/∂σ (and for `[0; 1]`, which is
/// `[v; g]`), the m + 2 equations reduce to three in (dλ, dσ, φ). That replaces the
/// (m + 2)-square factorisation of every iterate by three solves with B.
pub(super) enum NewtonLu {
    Whole(nalgebra::linalg::LU<f64, nalgebra::Dyn, nalgebra::Dyn>),
    Eliminated(Box<Eliminated>),
}

/// [`NewtonLu::Eliminated`]: u_λ of `[u_λ; ξ_λ] = B⁻¹ [∂R̂/∂λ; 0]` and u_σ likewise, v of
/// `[v; g] = B⁻¹ [0; 1]`, the rows ∂g/∂x and tᵀ, and the LU of the 3 × 3 matrix of (dλ, dσ, φ)
/// (B's own LU stays with the iterate's augmented system).
pub(super) struct Eliminated {
    pub(super) u: [DVector<f64>; 2],
    pub(super) gx: DVector<f64>,
    pub(super) tx: DVector<f64>,
    pub(super) v: DVector<f64>,
    pub(super) small: nalgebra::LU<f64, nalgebra::U3, nalgebra::U3>,
}

impl NewtonLu {
    /// `N z = rhs` (rhs: R̂'s rows, then g's, then the tangent row's).
    pub(super) fn solve(&self, rhs: &DVector<f64>, bordered: &Lu) -> Option<DVector<f64>> {
        match self {
            NewtonLu::Whole(lu) => lu.solve(rhs),
            NewtonLu::Eliminated(e) => {
                let m = e.v.len();
                let (u0, xi0) = bordered_solve(bordered, &rhs.rows(0, m))?;
                let b = nalgebra::Vector3::new(-xi0, rhs[m] - e.gx.dot(&u0), rhs[m + 1] - e.tx.dot(&u0));
                let z = e.small.solve(&b)?;
                let mut out = DVector::zeros(m + 2);
                let mut dx = out.rows_mut(0, m);
                dx.copy_from(&u0);
                dx.axpy(-z[0], &e.u[0], 1.0);
                dx.axpy(-z[1], &e.u[1], 1.0);
                dx.axpy(z[2], &e.v, 1.0);
                (out[m], out[m + 1]) = (z[0], z[1]);
                out.iter().all(|x| x.is_finite()).then_some(out)
            }
        }
    }

    /// The elimination at an iterate whose augmented system is `aug` (the whole J tested, v in
    /// the whole space), with the tangent row t.
    pub(super) fn eliminate(aug: &Augmented, t: &DVector<f64>) -> Option<Self> {
        let m = aug.r.len();
        let (ul, xl) = bordered_solve(&aug.bordered, &aug.rl.rows(0, m))?;
        let (us, xs) = bordered_solve(&aug.bordered, &aug.rs.rows(0, m))?;
        let tx = t.rows(0, m).clone_owned();
        // J dx + b ξ = R̂ − ∂R̂/∂λ dλ − ∂R̂/∂σ dσ with ξ = ξ₀ − ξ_λ dλ − ξ_σ dσ + g φ held at
        // zero, and the rows of g and of the tangent.
        #[rustfmt::skip]
        let small = nalgebra::Matrix3::new(
            -xl, -xs, aug.g,
            aug.gl - aug.gx.dot(&ul), aug.gs - aug.gx.dot(&us), aug.gx.dot(&aug.v),
            t[m] - tx.dot(&ul), t[m + 1] - tx.dot(&us), tx.dot(&aug.v),
        )
        .lu();
        Some(NewtonLu::Eliminated(Box::new(Eliminated {
            u: [ul, us],
            gx: aug.gx.clone(),
            tx,
            v: aug.v.clone(),
            small,
        })))
    }
}

/// `[u; ξ] = B⁻¹ [f; 0]` with B's LU `bordered`.
pub(super) fn bordered_solve(bordered: &Lu, f: &nalgebra::DVectorView<'_, f64>) -> Option<(DVector<f64>, f64)> {
    let m = f.len();
    let mut top = DVector::zeros(m + 1);
    top.rows_mut(0, m).copy_from(f);
    let s = bordered.solve(&top)?;
    Some((s.rows(0, m).clone_owned(), s[m]))
}

/// The unit tangent `[[augmented Jacobian], [rowᵀ]] z = e_last`, normalised, from the bordered
/// matrix's LU (`m` unknowns, then λ and σ); None where it is singular or not finite.
pub(super) fn unit_tangent(lu: &NewtonLu, bordered: &Lu, m: usize) -> Option<DVector<f64>> {
    let mut e = DVector::zeros(m + 2);
    e[m + 1] = 1.0;
    let z = lu.solve(&e, bordered)?;
    let norm = z.norm();
    (norm.is_finite() && norm > 0.0).then(|| z / norm)
}

/// A fold curve's walk: its plane, the borders b and c, ∂R̂/∂s (constant) on a torque-scale
/// plane, or the family of problems on a mechanism parameter's.
pub(super) struct Walk<'a> {
    pub(super) plane: Plane,
    pub(super) b: DVector<f64>,
    pub(super) c: DVector<f64>,
    pub(super) rs: DVector<f64>,
    /// The unknowns whose rows and columns of J form the matrix tested for singularity (all of
    /// them for a fold).
    pub(super) block: Vec<usize>,
    /// The unknowns held at zero (the odd harmonics, on the half-frequency problem): their rows
    /// of R̂ and of the augmented Jacobian become `x_i = 0`.
    pub(super) pinned: Vec<usize>,
    /// Whether ∂g/∂(x, λ, p) are central differences (exact tangents, for the turning points of
    /// the second parameter) rather than one-sided ones (one Jacobian fewer per Newton iterate).
    pub(super) central: bool,
    pub(super) family: Option<&'a MechanismFamily<'a>>,
    pub(super) built: Built,
}

impl Walk<'_> {
    /// The parameters at (λ, σ): the problem's (n, Ω, s), and p on a mechanism plane.
    pub(super) fn at(&self, lambda: f64, sigma: f64) -> (At, Option<f64>) {
        match self.family {
            None => (self.plane.at(lambda, sigma), None),
            Some(f) => {
                let p = sigma * f.reference;
                (on_family(self.plane.at(lambda, f.scale), f, p), Some(p))
            }
        }
    }

    /// σ of a value of the second parameter (s, or p in its unit).
    pub(super) fn sigma(&self, value: f64) -> f64 {
        self.family.map_or(value, |f| value / f.reference)
    }

    /// The second parameter's value (s, or p) at σ.
    pub(super) fn second(&self, sigma: f64) -> f64 {
        self.family.map_or(sigma, |f| sigma * f.reference)
    }

    /// A point of the curve.
    pub(super) fn point(&self, at: &At, sigma: f64, arclength: f64, solution: HbmSolution) -> FoldCurvePoint {
        let mut p = self.plane.point(at, arclength, solution);
        p.parameter = self.second(sigma);
        p
    }
}

impl Hbm {
    /// `[[M, b], [cᵀ, 0]]`.
    pub(super) fn border(mat: &DMatrix<f64>, b: &DVector<f64>, c: &DVector<f64>) -> DMatrix<f64> {
        let m = mat.nrows();
        let mut out = DMatrix::zeros(m + 1, m + 1);
        out.view_mut((0, 0), (m, m)).copy_from(mat);
        out.view_mut((0, m), (m, 1)).copy_from(b);
        out.view_mut((m, 0), (1, m)).copy_from(&c.transpose());
        out
    }

    /// The plane `kind` scaled at the problem's current parameters.
    pub(super) fn plane(&self, kind: FoldPlane) -> Plane {
        Plane { kind, p_ref: self.omega, omega: self.omega }
    }

    /// The augmented system at x, `at` and p (on a mechanism plane; `self` is then the
    /// problem's layout only, every number comes from the family's problems).
    pub(super) fn augmented(
        &mut self,
        x: &[f64],
        at: &At,
        p: Option<f64>,
        walk: &mut Walk,
    ) -> Result<Augmented, HbmError> {
        let order = at.order;
        let m = self.unknowns();
        let Walk { plane, b, c, rs, block, family, built, pinned, central } = walk;
        let (param, scale) = (plane.param(), plane.per_unit());
        let hbm = problem(self, built, *family, p)?;
        hbm.assemble(x, at, Some(param));
        let (r, j, rl) = (hbm.rhat.clone(), hbm.jac.clone(), &hbm.gp * scale);
        let idx = &*block;
        let mb = idx.len();
        let mut e = DVector::zeros(mb + 1);
        e[mb] = 1.0;
        // The bordered matrix of Jᵀ (borders swapped) is the transpose of J's: one LU for both.
        let lu = if mb == m {
            Lu::new(&Self::border(&j, b, c))
        } else {
            Lu::new(&Self::border(&DMatrix::from_fn(mb, mb, |a, b| j[(idx[a], idx[b])]), b, c))
        };
        let sv = lu.solve(&e).ok_or(HbmError::Singular { order })?;
        let sw = lu.solve_transposed(&e).ok_or(HbmError::Singular { order })?;
        let (vb, g) = (sv.rows(0, mb).clone_owned(), sv[mb]);
        let wb = sw.rows(0, mb).clone_owned();
        // v and w in the whole space (zero off the block).
        let (mut v, mut w) = (DVector::zeros(m), DVector::zeros(m));
        for (a, &i) in idx.iter().enumerate() {
            (v[i], w[i]) = (vb[a], wb[a]);
        }
        // J and ∂R̂/∂λ at x ± h v̂.
        let vn = v.norm();
        if !(vn.is_finite() && vn > 0.0) {
            return Err(HbmError::NonFinite { order });
        }
        let h = if *central { FD_STEP } else { FD_STEP_ONE_SIDED } / vn;
        let shifted = |sign: f64| -> Vec<f64> { x.iter().zip(v.iter()).map(|(xi, vi)| xi + sign * h * vi).collect() };
        hbm.assemble(&shifted(1.0), at, Some(param));
        let (gx, gl) = if *central {
            let (jp, rlp) = (hbm.jac.clone(), hbm.gp.clone());
            hbm.assemble(&shifted(-1.0), at, Some(param));
            (-((&jp - &hbm.jac).transpose() * &w) / (2.0 * h), -scale * w.dot(&(&rlp - &hbm.gp)) / (2.0 * h))
        } else {
            // J and ∂R̂/∂λ at x are `j` and `rl` (scaled).
            (-((&hbm.jac - &j).transpose() * &w) / h, -w.dot(&(&hbm.gp * scale - &rl)) / h)
        };
        // ∂R̂/∂σ and ∂g/∂σ: s multiplies the excitation, which does not depend on x (so ∂J/∂s = 0);
        // p is differenced between the problems built at p ± h (per unit σ = p / reference).
        let (rs, gs) = match (*family, p) {
            (Some(f), Some(p)) => {
                let hp = FD_STEP * f.reference;
                let mut side = |q: f64| -> Result<(DVector<f64>, DMatrix<f64>), HbmError> {
                    let other = built.at(f, q)?;
                    other.assemble(x, &on_family(*at, f, q), Some(param));
                    Ok((other.rhat.clone(), other.jac.clone()))
                };
                let (r_up, j_up) = side(p + hp)?;
                let (r_down, j_down, per) = if *central {
                    let (r_down, j_down) = side(p - hp)?;
                    (r_down, j_down, f.reference / (2.0 * hp))
                } else {
                    (r.clone(), j.clone(), f.reference / hp)
                };
                ((r_up - r_down) * per, -w.dot(&((j_up - j_down) * &v)) * per)
            }
            _ => (rs.clone(), 0.0),
        };
        let (v, w) = (vb, wb);
        let mut aug = Augmented { r, j, rl, rs, g, gx, gl, gs, v, w, bordered: lu };
        if !pinned.is_empty() {
            // By the symmetry the even rows do not depend on the odd unknowns at an even state
            // (and g is even in them), so these columns are zero there: the pinned rows only
            // keep the odd unknowns at zero, and the system stays regular at a period doubling.
            for &i in pinned.iter() {
                aug.r[i] = x[i];
                aug.j.row_mut(i).fill(0.0);
                aug.j.column_mut(i).fill(0.0);
                aug.j[(i, i)] = 1.0;
                (aug.rl[i], aug.rs[i], aug.gx[i]) = (0.0, 0.0, 0.0);
            }
        }
        Ok(aug)
    }

    /// The unknowns whose rows and columns of J form the matrix `test` keeps singular.
    pub(super) fn tested(&self, test: Singularity) -> Vec<usize> {
        let m = self.unknowns();
        match test {
            Singularity::Jacobian => (0..m).collect(),
            Singularity::Block { first, count } => (first * self.nb..((first + count) * self.nb).min(m)).collect(),
            // Slot i of a coordinate holds harmonic ⌈i/2⌉ (0 the mean, then cosine and sine).
            Singularity::HalfPeriod => (0..m).filter(|&i| self.odd_slot(i)).collect(),
            Singularity::HalfPeriodBlock { first, count } => {
                (first * self.nb..((first + count) * self.nb).min(m)).filter(|&i| self.odd_slot(i)).collect()
            }
        }
    }

    /// Whether unknown i holds an odd harmonic: slot i of a coordinate holds harmonic ⌈i/2⌉.
    pub(super) fn odd_slot(&self, i: usize) -> bool {
        (i % self.nb).div_ceil(2) % 2 == 1
    }

    /// The unknowns a curve of `test` holds at zero: every odd harmonic on the half-frequency
    /// problem, none otherwise.
    pub(super) fn pinned(&self, test: Singularity) -> Vec<usize> {
        if test.on_half_period() { (0..self.unknowns()).filter(|&i| self.odd_slot(i)).collect() } else { Vec::new() }
    }

    /// The start of a walk in `kind` at x, `at` and p: borders from the singular vectors of J's
    /// smallest singular value, and on a torque-scale plane ∂R̂/∂s, which depends on neither x
    /// nor the other parameters (s multiplies the excitation).
    pub(super) fn walk<'a>(
        &mut self,
        kind: FoldPlane,
        test: Singularity,
        family: Option<&'a MechanismFamily<'a>>,
        x: &[f64],
        at: &At,
        p: Option<f64>,
    ) -> Result<Walk<'a>, HbmError> {
        if matches!(kind, FoldPlane::Speed { .. }) && family.is_some_and(|f| f.speed) {
            return Err(HbmError::Invalid(
                "a speed family needs an order or torque plane (the speed is its second parameter)".into(),
            ));
        }
        if matches!(kind, FoldPlane::Torque { .. }) && family.is_none() {
            return Err(HbmError::Invalid("a torque plane needs a family's parameter as its second".into()));
        }
        let plane = self.plane(kind);
        let block = self.tested(test);
        let mut built = Built::default();
        let hbm = problem(self, &mut built, family, p)?;
        hbm.assemble(x, at, Some(Parameter::TorqueScale { order: at.order }));
        let rs = hbm.gp.clone();
        let mb = block.len();
        let jb = DMatrix::from_fn(mb, mb, |a, b| hbm.jac[(block[a], block[b])]);
        let unit = DVector::from_element(mb, 1.0 / (mb as f64).sqrt());
        // b and c only have to keep the bordered matrix regular: not orthogonal to J_b's left
        // and right null vectors. A walk starts near a singular point, where one step of inverse
        // iteration from a flat vector already points along them; the SVD (several times the
        // cost of an LU) only where that step fails.
        let lu = Lu::new(&jb);
        let inverse = |x: Option<DVector<f64>>| x.map(|x| x.normalize()).filter(|x| x.iter().all(|v| v.is_finite()));
        let (b, c) = match (inverse(lu.solve_transposed(&unit)), inverse(lu.solve(&unit))) {
            (Some(b), Some(c)) => (b, c),
            _ => {
                let svd = jb.svd(true, true);
                let k = svd.singular_values.imin();
                let b = svd.u.as_ref().map_or_else(|| unit.clone(), |u| u.column(k).clone_owned());
                let c = svd.v_t.as_ref().map_or(unit, |v| v.row(k).transpose());
                (b, c)
            }
        };
        let pinned = self.pinned(test);
        Ok(Walk { plane, b, c, rs, block, pinned, family, built, central: false })
    }

    /// The augmented system at y = (x, λ, σ).
    pub(super) fn augmented_at(&mut self, y: &DVector<f64>, walk: &mut Walk) -> Result<Augmented, HbmError> {
        let m = self.unknowns();
        let x: Vec<f64> = y.rows(0, m).iter().copied().collect();
        let (at, p) = walk.at(y[m], y[m + 1]);
        self.augmented(&x, &at, p, walk)
    }

    /// The augmented Jacobian `[[J, ∂R̂/∂λ, ∂R̂/∂σ], [∂g/∂x, ∂g/∂λ, ∂g/∂σ]]` of `aug` bordered
    /// below by `row`, factorised whole.
    pub(super) fn whole_newton(aug: &Augmented, row: &DVector<f64>) -> NewtonLu {
        let m = aug.r.len();
        let mut mat = DMatrix::zeros(m + 2, m + 2);
        mat.view_mut((0, 0), (m, m)).copy_from(&aug.j);
        mat.view_mut((0, m), (m, 1)).copy_from(&aug.rl);
        mat.view_mut((0, m + 1), (m, 1)).copy_from(&aug.rs);
        mat.view_mut((m, 0), (1, m)).copy_from(&aug.gx.transpose());
        mat[(m, m)] = aug.gl;
        mat[(m, m + 1)] = aug.gs;
        mat.view_mut((m + 1, 0), (1, m + 2)).copy_from(&row.transpose());
        NewtonLu::Whole(mat.lu())
    }

    /// `f` with the walk's ∂g/∂(x, λ, p) taken by central differences (the exact tangents that
    /// locate a turning point of the second parameter), the walk's choice restored after.
    pub(super) fn with_central<R>(&mut self, walk: &mut Walk, f: impl FnOnce(&mut Self, &mut Walk) -> R) -> R {
        let before = std::mem::replace(&mut walk.central, true);
        let r = f(self, walk);
        walk.central = before;
        r
    }

    /// The unit tangent of the fold curve at y, oriented along `row`.
    pub(super) fn fold_tangent(
        &mut self,
        y: &DVector<f64>,
        walk: &mut Walk,
        row: &DVector<f64>,
    ) -> Result<(DVector<f64>, Augmented), HbmError> {
        let m = self.unknowns();
        let aug = self.augmented_at(y, walk)?;
        let z =
            unit_tangent(&Self::whole_newton(&aug, row), &aug.bordered, m).ok_or(HbmError::Singular { order: y[m] })?;
        Ok((z, aug))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The block elimination solves the fold curve's Newton system as the whole (m + 2)-square
    /// LU does (the independent route), for a nearly singular J as at a fold (one singular
    /// value 1e-9) and for a regular one: agreement to 1e-12 of the solution's size.
    #[test]
    pub(super) fn elimination_solves_the_whole_newton_system() {
        let m = 9;
        // A deterministic spread of entries in (−1, 1).
        let mut seed = 12345_u64;
        let mut next = move || {
            seed = seed.wrapping_mul(6364136223846793005).wrapping_add(1442695040888963407);
            ((seed >> 11) as f64 / (1u64 << 53) as f64) * 2.0 - 1.0
        };
        for smallest in [1e-9, 0.3] {
            let a = DMatrix::from_fn(m, m, |_, _| next());
            let svd = a.svd(true, true);
            let mut sv = DVector::from_fn(m, |i, _| 1.0 + i as f64);
            sv[0] = smallest;
            let (u, vt) = (svd.u.unwrap(), svd.v_t.unwrap());
            let j = &u * DMatrix::from_diagonal(&sv) * &vt;
            let (b, c) = (u.column(0).clone_owned(), vt.row(0).transpose());
            let vec = |n: &mut dyn FnMut() -> f64| DVector::from_fn(m, |_, _| n());
            let (rl, rs, gx, r) = (vec(&mut next), vec(&mut next), vec(&mut next), vec(&mut next));
            let t = DVector::from_fn(m + 2, |_, _| next());
            let (gl, gs, gres, tau) = (next(), next(), next(), next());
            let bordered = Lu::new(&Hbm::border(&j, &b, &c));
            let mut e = DVector::zeros(m + 1);
            e[m] = 1.0;
            let sv_ = bordered.solve(&e).unwrap();
            let (v, g) = (sv_.rows(0, m).clone_owned(), sv_[m]);
            let aug = Augmented {
                r: r.clone(),
                j: j.clone(),
                rl: rl.clone(),
                rs: rs.clone(),
                g,
                gx: gx.clone(),
                gl,
                gs,
                v,
                w: DVector::zeros(m),
                bordered,
            };
            let mut whole = DMatrix::zeros(m + 2, m + 2);
            whole.view_mut((0, 0), (m, m)).copy_from(&j);
            whole.view_mut((0, m), (m, 1)).copy_from(&rl);
            whole.view_mut((0, m + 1), (m, 1)).copy_from(&rs);
            whole.view_mut((m, 0), (1, m)).copy_from(&gx.transpose());
            (whole[(m, m)], whole[(m, m + 1)]) = (gl, gs);
            whole.view_mut((m + 1, 0), (1, m + 2)).copy_from(&t.transpose());
            let mut rhs = DVector::zeros(m + 2);
            rhs.rows_mut(0, m).copy_from(&r);
            (rhs[m], rhs[m + 1]) = (gres, tau);
            let want = whole.lu().solve(&rhs).unwrap();
            let got = NewtonLu::eliminate(&aug, &t).unwrap().solve(&rhs, &aug.bordered).unwrap();
            let err = (&got - &want).amax() / want.amax();
            assert!(err < 1e-12, "smallest singular value {smallest}: relative difference {err:e}");
        }
    }
}
