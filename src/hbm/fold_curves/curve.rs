//! Two-parameter continuation of folds of the harmonic balance in (excitation order n or mean
//! speed Ω, torque scale s or a mechanism parameter p): the jump boundary of a response in the
//! (order, torque) plane, and its cusp, where the two folds of a jump meet and the jump
//! disappears.
//!
//! A fold of a branch in n at fixed s is a point where the Jacobian `J = ∂R̂/∂x` of the balance
//! is singular. It is followed by the minimally augmented system (Govaerts, *Numerical Methods
//! for Bifurcations of Dynamical Equilibria*, SIAM 2000, §4.3.2): with vectors b and c that keep
//! the bordered matrix regular,
//!
//! `[[J, b], [cᵀ, 0]] [v; g] = [0; 1]`, `[[Jᵀ, c], [bᵀ, 0]] [w; g] = [0; 1]`,
//!
//! g(x, n, s) vanishes exactly where J is singular, and the fold curve is the solution set of the
//! m + 1 equations `R̂(x, n, s) = 0, g(x, n, s) = 0` in the m + 2 unknowns (x, n, s), followed by
//! pseudo-arclength continuation. The derivatives of g are `∂g/∂z = −wᵀ (∂J/∂z) v`: for the
//! unknowns, `−wᵀ (J(x + hv) − J(x − hv)) / 2h` (the symmetry of second derivatives turns the
//! directional derivative of J along v into the difference of two Jacobians); for the order, the
//! same difference of `∂R̂/∂n`; for the torque scale, zero, since s multiplies the excitation,
//! which does not depend on x. Newton's iterates take the one-sided difference from J(x), which
//! they have anyway (one Jacobian instead of two; g itself is exact, so the point converged to
//! is the same), and stop once the contraction shows the next step below the tolerance
//! (`settled`); on a fold curve their (m + 2)-square matrix is solved by block elimination on
//! the bordered matrix that g already factorised (`NewtonLu`); the tangents that locate a
//! turning point of s take central differences and the whole matrix. After
//! every point b and c take the new w and v, so the bordered
//! matrices stay far from singular along the curve. A step is retried shorter when the tangent
//! turned by more than acos 0.95 or the tested block's null vector by more than acos `NULL_TURN`
//! (the corrector has then landed on a neighbouring curve, as near an onset whose two legs are
//! close in state).
//!
//! Period doublings are followed the same way on the problem of half the base frequency
//! (`Singularity::HalfPeriod`): at its states of even harmonics only (the period-1 states) the
//! odd harmonics decouple, and g is built on the odd-harmonic block of J, whose singularity is a
//! Floquet multiplier −1; the odd unknowns are pinned at zero, so the curve stays on the
//! period-1 states. Along an order-torque curve of a parametric resonance the least torque is
//! the tongue's tip (an extremum of s that is not a cusp).
//!
//! The second parameter may also be a mechanism parameter p (a pivot's damping, an absorber's
//! tuning) at a fixed torque scale, through a [`MechanismFamily`] that builds the problem at any p:
//! the same system with ∂R̂/∂p and `∂g/∂p = −wᵀ (∂J/∂p) v` by differences between problems
//! built at p ± h (one-sided in Newton's iterates, as for x), as the mechanism offers no
//! derivative in p (see its docs).
//!
//! Along the curve s has a minimum at a cusp (there the projection of the fold curve on the
//! (n, s) plane has its spike: in the normal form `x³ − s x − n = 0` the folds are
//! `s = 3x², n = −2x³`): a sign change of ds/dσ between points, located by a secant search
//! on ds/dσ to |ds/dσ| ≤ 1e-10; a cusp when dn/dσ vanishes with it.

use super::continuation::Illinois;
use super::{At, Hbm, HbmError, HbmSolution, Parameter};
use nalgebra::{DMatrix, DVector};

/// Relative step of the differences of the Jacobian along the null vector v (|v| = 1, in rad):
/// central differences err by O(h²) of the third derivatives and by O(ε/h) of rounding.
const FD_STEP: f64 = 1e-5;

/// The step of the one-sided differences of the Newton iterations: they err by O(h) of the
/// second derivatives and by O(ε/h) of rounding, balanced near √ε. Newton only needs ∂g/∂x to
/// that accuracy (the residual g is exact, so the converged point is the same); the tangents
/// at turning points of the second parameter take central differences (`Walk::central`).
const FD_STEP_ONE_SIDED: f64 = 1e-7;

/// Smallest |cos| between the tested block's null vectors at successive points of a curve.
const NULL_TURN: f64 = 0.9;

/// The plane of a fold curve: the torque scale s and either the excitation order n (at the
/// problem's mean speed) or the mean speed Ω (at a fixed order); or the torque scale against a
/// [`MechanismFamily`]'s p at a fixed order and speed.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum FoldPlane {
    /// (n, s) at the problem's mean speed.
    Order,
    /// (Ω, s) at excitation order `order`.
    Speed {
        /// The fixed excitation order n.
        order: f64,
    },
    /// (s, p) at excitation order `order` and the problem's mean speed: the torque scale is the
    /// first parameter, so the second must be a family's p.
    Torque {
        /// The fixed excitation order n.
        order: f64,
    },
}

/// A plane with the scale of its first parameter: λ = n, or λ = Ω/Ω_ref (so that both
/// parameters and the coefficients in rad weigh alike in the arclength).
#[derive(Debug, Clone, Copy)]
struct Plane {
    kind: FoldPlane,
    p_ref: f64,
    /// Ω of an order plane.
    omega: f64,
}

impl Plane {
    fn at(&self, lambda: f64, scale: f64) -> At {
        match self.kind {
            FoldPlane::Order => At { order: lambda, omega: self.omega, scale },
            FoldPlane::Speed { order } => At { order, omega: lambda * self.p_ref, scale },
            FoldPlane::Torque { order } => At { order, omega: self.omega, scale: lambda },
        }
    }

    fn lambda(&self, at: &At) -> f64 {
        match self.kind {
            FoldPlane::Order => at.order,
            FoldPlane::Speed { .. } => at.omega / self.p_ref,
            FoldPlane::Torque { .. } => at.scale,
        }
    }

    fn param(&self) -> Parameter {
        match self.kind {
            FoldPlane::Order => Parameter::Order,
            FoldPlane::Speed { order } => Parameter::Speed { order },
            FoldPlane::Torque { order } => Parameter::TorqueScale { order },
        }
    }

    /// ∂λ/∂(the parameter's own unit): Ω_ref on a speed plane (λ = Ω/Ω_ref), else 1.
    fn per_unit(&self) -> f64 {
        match self.kind {
            FoldPlane::Speed { .. } => self.p_ref,
            FoldPlane::Order | FoldPlane::Torque { .. } => 1.0,
        }
    }

    fn point(&self, at: &At, arclength: f64, solution: HbmSolution) -> FoldCurvePoint {
        FoldCurvePoint { order: at.order, omega: at.omega, scale: at.scale, parameter: at.scale, arclength, solution }
    }
}

/// One point of a fold curve.
#[derive(Debug, Clone)]
pub struct FoldCurvePoint {
    /// Excitation order n.
    pub order: f64,
    /// Mean speed Ω, rad/s.
    pub omega: f64,
    /// Torque scale s (the excitation amplitudes are s·T_k).
    pub scale: f64,
    /// The plane's second parameter: s on a torque-scale plane, the mechanism parameter p (its
    /// unit) on a [`MechanismFamily`]'s.
    pub parameter: f64,
    /// Arclength along the curve, in the norm of (coefficients in rad, n, s or p / reference).
    pub arclength: f64,
    /// The periodic state at the fold.
    pub solution: HbmSolution,
}

/// A point of a fold curve's plane.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ParameterPoint {
    /// Excitation order n.
    pub order: f64,
    /// Mean speed Ω, rad/s.
    pub omega: f64,
    /// Torque scale s.
    pub scale: f64,
    /// The plane's second parameter: s, or the mechanism parameter p.
    pub parameter: f64,
}

/// Why a fold curve ended.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum FoldCurveEnd {
    /// The curve left the (n, s) box it was asked for.
    LeftBox,
    /// The largest number of points was reached.
    MaxPoints,
    /// The corrector failed at every step down to the smallest.
    StepTooSmall,
}

/// A fold curve in (n, s).
#[derive(Debug, Clone)]
pub struct FoldCurve {
    /// The points, in the order followed.
    pub points: Vec<FoldCurvePoint>,
    /// The cusps met, located: two folds meet there, and on the far side in s the response has
    /// no jump (ds/dσ and dn/dσ vanish together along the curve).
    pub cusps: Vec<ParameterPoint>,
    /// The other extrema of s along the curve (dn/dσ not zero there): the least or largest
    /// torque of a jump region's boundary without a cusp (where an isola is born, say).
    pub scale_extrema: Vec<ParameterPoint>,
    /// Why it ended.
    pub end: FoldCurveEnd,
}

/// Settings of a fold-curve continuation.
#[derive(Debug, Clone, Copy)]
pub struct FoldCurveOptions {
    /// Range of the plane's first parameter, n or Ω in rad/s (the curve ends on leaving it).
    pub range: (f64, f64),
    /// Range of the second parameter, the torque scale s or a mechanism parameter p in its
    /// unit (likewise).
    pub scales: (f64, f64),
    /// First and largest arclength step.
    pub ds: f64,
    /// Largest arclength step.
    pub ds_max: f64,
    /// Smallest step before giving up.
    pub ds_min: f64,
    /// Largest number of points.
    pub max_points: usize,
    /// Newton iterations per corrector.
    pub max_iter: usize,
    /// Newton tolerance on the step (max norm, rad and the parameters).
    pub tol: f64,
    /// The matrix kept singular along the curve.
    pub test: Singularity,
}

impl Default for FoldCurveOptions {
    fn default() -> Self {
        Self {
            range: (0.0, f64::INFINITY),
            scales: (0.0, f64::INFINITY),
            ds: 0.01,
            ds_max: 0.05,
            ds_min: 1e-8,
            max_points: 2000,
            max_iter: 12,
            tol: 1e-10,
            test: Singularity::Jacobian,
        }
    }
}

/// A family of problems along a mechanism parameter p (a pivot's damping, an absorber's
/// tuning), the plane's second parameter in place of the torque scale.
///
/// The residual depends on p through the mechanism, which the engine builds once (its mass
/// matrix, the joints' laws): there is no ∂R̂/∂p in closed form, and no way to change p in place.
/// So `build(p)` makes the whole problem at p, and ∂R̂/∂p and `∂g/∂p = −wᵀ (∂J/∂p) v` are
/// differences of problems built at p and p ± h, h = 1e-5 · `reference`: central (O(h²) of the
/// third derivatives) for tangents at turning points, one-sided in Newton's iterates (the
/// residual is linear in a damping, so both are exact there up to rounding).
pub struct MechanismFamily<'a> {
    /// The problem at p: the same mechanism and route at every p, so the same unknowns.
    pub build: &'a dyn Fn(f64) -> Result<Hbm, HbmError>,
    /// The torque scale s held fixed.
    pub scale: f64,
    /// The size of p, its unit (> 0): the arclength weighs p / reference like the order and the
    /// coefficients in rad, and the difference step is relative to it.
    pub reference: f64,
    /// Whether p is the mean speed Ω itself (rad/s), on an order plane: the (n, Ω) plane at a
    /// fixed torque. Each state is then evaluated at Ω = p (the problems are built there too),
    /// and ∂R̂/∂Ω, ∂g/∂Ω are differences between Ω = p and p ± h like any other p's.
    pub speed: bool,
}

impl std::fmt::Debug for MechanismFamily<'_> {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("MechanismFamily")
            .field("scale", &self.scale)
            .field("reference", &self.reference)
            .field("speed", &self.speed)
            .finish()
    }
}

/// Problems built at recent values of p, the last few kept (a corrector needs p and p ± h at
/// each iterate, and the tangent the same again at the converged point).
#[derive(Default)]
struct Built {
    problems: Vec<(f64, Hbm)>,
}

impl Built {
    const KEPT: usize = 6;

    /// The problem at p, built unless kept.
    fn at(&mut self, family: &MechanismFamily<'_>, p: f64) -> Result<&mut Hbm, HbmError> {
        let k = match self.problems.iter().position(|(q, _)| q.to_bits() == p.to_bits()) {
            Some(k) => k,
            None => {
                if !p.is_finite() {
                    return Err(HbmError::NonFinite { order: f64::NAN });
                }
                let hbm = (family.build)(p)?;
                if self.problems.len() >= Self::KEPT {
                    self.problems.remove(0);
                }
                self.problems.push((p, hbm));
                self.problems.len() - 1
            }
        };
        Ok(&mut self.problems[k].1)
    }
}

/// The augmented system's pieces at one point: R̂, J, ∂R̂/∂λ, ∂R̂/∂σ (σ the second parameter:
/// s, or p / reference), and g with its gradient in (x, λ, σ), v and w.
struct Augmented {
    r: DVector<f64>,
    j: DMatrix<f64>,
    rl: DVector<f64>,
    rs: DVector<f64>,
    g: f64,
    gx: DVector<f64>,
    gl: f64,
    gs: f64,
    v: DVector<f64>,
    w: DVector<f64>,
    /// The LU of the tested block bordered, `[[J_b, b], [cᵀ, 0]]`.
    bordered: Lu,
}

/// A fold curve's walk: its plane, the borders b and c, ∂R̂/∂s (constant) on a torque-scale
/// plane, or the family of problems on a mechanism parameter's.
/// Whether a Newton iteration whose last two steps (max norm) were `step` and `previous` has
/// settled to `tol` without one more iterate: it contracts at least by step/previous per
/// iterate (≤ 1/2 asked), so the next step, which bounds the error left, is at most
/// step²/previous. The iterate that step verifies costs a whole Jacobian set on a fold curve.
fn settled(step: f64, previous: f64, tol: f64) -> bool {
    previous.is_finite() && step <= 0.5 * previous && step * step <= tol * previous
}

/// A converged corrector: the point, its Newton iterations, whether the last iterate's own step
/// was left out as [`settled`], and the last Newton matrix's LU and augmented system (at the
/// iterate one step before y).
struct Corrected {
    y: DVector<f64>,
    iterations: usize,
    skipped: bool,
    lu: NewtonLu,
    aug: Augmented,
}

type Lu = super::lu::DenseLu;

/// The fold curve's Newton matrix `N = [[J, ∂R̂/∂λ, ∂R̂/∂σ], [∂g/∂x, ∂g/∂λ, ∂g/∂σ], [tᵀ]]`
/// ready to solve: factorised whole, or, on a fold curve (the whole J tested, nothing pinned),
/// by block elimination on the bordered matrix `B = [[J, b], [cᵀ, 0]]` whose LU the iterate has
/// already (Govaerts 2000, §3.2, the bordering algorithms): with `φ = cᵀ dx` as an extra unknown
/// and `B [u_k; ξ_k]` solved for the columns ∂R̂/∂λ, ∂R̂/∂σ (and for `[0; 1]`, which is
/// `[v; g]`), the m + 2 equations reduce to three in (dλ, dσ, φ). That replaces the
/// (m + 2)-square factorisation of every iterate by three solves with B.
enum NewtonLu {
    Whole(nalgebra::linalg::LU<f64, nalgebra::Dyn, nalgebra::Dyn>),
    Eliminated(Box<Eliminated>),
}

/// [`NewtonLu::Eliminated`]: u_λ of `[u_λ; ξ_λ] = B⁻¹ [∂R̂/∂λ; 0]` and u_σ likewise, v of
/// `[v; g] = B⁻¹ [0; 1]`, the rows ∂g/∂x and tᵀ, and the LU of the 3 × 3 matrix of (dλ, dσ, φ)
/// (B's own LU stays with the iterate's augmented system).
struct Eliminated {
    u: [DVector<f64>; 2],
    gx: DVector<f64>,
    tx: DVector<f64>,
    v: DVector<f64>,
    small: nalgebra::LU<f64, nalgebra::U3, nalgebra::U3>,
}

impl NewtonLu {
    /// `N z = rhs` (rhs: R̂'s rows, then g's, then the tangent row's).
    fn solve(&self, rhs: &DVector<f64>, bordered: &Lu) -> Option<DVector<f64>> {
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
    fn eliminate(aug: &Augmented, t: &DVector<f64>) -> Option<Self> {
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
fn bordered_solve(bordered: &Lu, f: &nalgebra::DVectorView<'_, f64>) -> Option<(DVector<f64>, f64)> {
    let m = f.len();
    let mut top = DVector::zeros(m + 1);
    top.rows_mut(0, m).copy_from(f);
    let s = bordered.solve(&top)?;
    Some((s.rows(0, m).clone_owned(), s[m]))
}

/// The unit tangent `[[augmented Jacobian], [rowᵀ]] z = e_last`, normalised, from the bordered
/// matrix's LU (`m` unknowns, then λ and σ); None where it is singular or not finite.
fn unit_tangent(lu: &NewtonLu, bordered: &Lu, m: usize) -> Option<DVector<f64>> {
    let mut e = DVector::zeros(m + 2);
    e[m + 1] = 1.0;
    let z = lu.solve(&e, bordered)?;
    let norm = z.norm();
    (norm.is_finite() && norm > 0.0).then(|| z / norm)
}

struct Walk<'a> {
    plane: Plane,
    b: DVector<f64>,
    c: DVector<f64>,
    rs: DVector<f64>,
    /// The unknowns whose rows and columns of J form the matrix tested for singularity (all of
    /// them for a fold).
    block: Vec<usize>,
    /// The unknowns held at zero (the odd harmonics, on the half-frequency problem): their rows
    /// of R̂ and of the augmented Jacobian become `x_i = 0`.
    pinned: Vec<usize>,
    /// Whether ∂g/∂(x, λ, p) are central differences (exact tangents, for the turning points of
    /// the second parameter) rather than one-sided ones (one Jacobian fewer per Newton iterate).
    central: bool,
    family: Option<&'a MechanismFamily<'a>>,
    built: Built,
}

impl Walk<'_> {
    /// The parameters at (λ, σ): the problem's (n, Ω, s), and p on a mechanism plane.
    fn at(&self, lambda: f64, sigma: f64) -> (At, Option<f64>) {
        match self.family {
            None => (self.plane.at(lambda, sigma), None),
            Some(f) => {
                let p = sigma * f.reference;
                (on_family(self.plane.at(lambda, f.scale), f, p), Some(p))
            }
        }
    }

    /// σ of a value of the second parameter (s, or p in its unit).
    fn sigma(&self, value: f64) -> f64 {
        self.family.map_or(value, |f| value / f.reference)
    }

    /// The second parameter's value (s, or p) at σ.
    fn second(&self, sigma: f64) -> f64 {
        self.family.map_or(sigma, |f| sigma * f.reference)
    }

    /// A point of the curve.
    fn point(&self, at: &At, sigma: f64, arclength: f64, solution: HbmSolution) -> FoldCurvePoint {
        let mut p = self.plane.point(at, arclength, solution);
        p.parameter = self.second(sigma);
        p
    }
}

/// `at` with the family's p where p is a parameter of the evaluation (a speed family's Ω).
fn on_family(at: At, family: &MechanismFamily<'_>, p: f64) -> At {
    if family.speed { At { omega: p, ..at } } else { at }
}

/// The problem at p: `base` on a torque-scale plane (p None), else the family's, built if need be.
fn problem<'h>(
    base: &'h mut Hbm,
    built: &'h mut Built,
    family: Option<&MechanismFamily<'_>>,
    p: Option<f64>,
) -> Result<&'h mut Hbm, HbmError> {
    match (family, p) {
        (Some(f), Some(p)) => built.at(f, p),
        _ => Ok(base),
    }
}

/// Which matrix a curve keeps singular.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum Singularity {
    /// The whole Jacobian: folds.
    #[default]
    Jacobian,
    /// The diagonal block of coordinates `first..first + count`: on the unison problem of
    /// identical absorbers (one representative, [`RoutedHbm`](super::RoutedHbm)'s reduction),
    /// the representative absorber's own block is the Jacobian of every non-unison wavenumber
    /// (the absorbers couple only through the rotor, which those motions leave alone), so its
    /// singularity is the loss of unison (a +1 branch point of the full set).
    Block {
        /// First coordinate of the block.
        first: usize,
        /// Number of coordinates.
        count: usize,
    },
    /// On the problem of half the base frequency ([`Symmetry::HalfPeriod`](super::Symmetry)),
    /// the block of the odd harmonics at states of even harmonics only (the period-1 states):
    /// there the odd harmonics decouple from the even ones at linear order, and the odd block is
    /// the Jacobian of the perturbations that change sign every excitation period, so its
    /// singularity is a period doubling (a Floquet multiplier −1 of the period-1 state). The
    /// curve's states are held on the even harmonics (the odd unknowns pinned at zero).
    HalfPeriod,
    /// Both at once: on the half-frequency problem of identical absorbers (one representative),
    /// the odd harmonics of the representative's own block (coordinates `first..first + count`):
    /// the Jacobian of the non-unison perturbations that change sign every excitation period, so
    /// its singularity is a period doubling that also breaks the unison (the absorbers swing at
    /// half the order against each other). The odd unknowns of every coordinate are pinned, as
    /// for [`Singularity::HalfPeriod`].
    HalfPeriodBlock {
        /// First coordinate of the block.
        first: usize,
        /// Number of coordinates.
        count: usize,
    },
}

impl Singularity {
    /// Whether the curve lives on the problem of half the base frequency (its odd unknowns
    /// pinned at zero).
    pub fn on_half_period(self) -> bool {
        matches!(self, Singularity::HalfPeriod | Singularity::HalfPeriodBlock { .. })
    }

    /// The test at half the base frequency of a unison-loss test (`Block` → `HalfPeriodBlock`;
    /// the whole Jacobian → `HalfPeriod`).
    pub fn halved(self) -> Singularity {
        match self {
            Singularity::Block { first, count } | Singularity::HalfPeriodBlock { first, count } => {
                Singularity::HalfPeriodBlock { first, count }
            }
            Singularity::Jacobian | Singularity::HalfPeriod => Singularity::HalfPeriod,
        }
    }
}

impl Hbm {
    /// `[[M, b], [cᵀ, 0]]`.
    fn border(mat: &DMatrix<f64>, b: &DVector<f64>, c: &DVector<f64>) -> DMatrix<f64> {
        let m = mat.nrows();
        let mut out = DMatrix::zeros(m + 1, m + 1);
        out.view_mut((0, 0), (m, m)).copy_from(mat);
        out.view_mut((0, m), (m, 1)).copy_from(b);
        out.view_mut((m, 0), (1, m)).copy_from(&c.transpose());
        out
    }

    /// The plane `kind` scaled at the problem's current parameters.
    fn plane(&self, kind: FoldPlane) -> Plane {
        Plane { kind, p_ref: self.omega, omega: self.omega }
    }

    /// The augmented system at x, `at` and p (on a mechanism plane; `self` is then the
    /// problem's layout only, every number comes from the family's problems).
    fn augmented(&mut self, x: &[f64], at: &At, p: Option<f64>, walk: &mut Walk) -> Result<Augmented, HbmError> {
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
    fn tested(&self, test: Singularity) -> Vec<usize> {
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
    fn odd_slot(&self, i: usize) -> bool {
        (i % self.nb).div_ceil(2) % 2 == 1
    }

    /// The unknowns a curve of `test` holds at zero: every odd harmonic on the half-frequency
    /// problem, none otherwise.
    fn pinned(&self, test: Singularity) -> Vec<usize> {
        if test.on_half_period() { (0..self.unknowns()).filter(|&i| self.odd_slot(i)).collect() } else { Vec::new() }
    }

    /// The start of a walk in `kind` at x, `at` and p: borders from the singular vectors of J's
    /// smallest singular value, and on a torque-scale plane ∂R̂/∂s, which depends on neither x
    /// nor the other parameters (s multiplies the excitation).
    fn walk<'a>(
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

    /// Newton's method on `R̂ = 0, g = 0` with one of (λ, σ) free: λ when `free_lambda`, else σ.
    fn fold_solve(
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
    /// [`Fold`](super::Fold)s): Newton's method on `R̂ = 0, g = 0` in (x, n) or (x, Ω).
    pub fn fold_at(&mut self, plane: FoldPlane, scale: f64, guess: &HbmSolution) -> Result<FoldCurvePoint, HbmError> {
        self.singular_at(plane, Singularity::Jacobian, scale, guess)
    }

    /// The singularity tests of the problem's non-unison motions: on the unison problem of
    /// identical absorbers ([`RoutedHbm::hbm_mut`](super::RoutedHbm::hbm_mut)), one
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
    fn singular_solve(
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

    /// Follows the fold curve in `plane` through `start` (from [`Hbm::fold_at`]) in the
    /// direction of increasing s when `up`, else decreasing, until it leaves the box of `opts`.
    pub fn continue_fold(
        &mut self,
        plane: FoldPlane,
        start: &FoldCurvePoint,
        up: bool,
        opts: &FoldCurveOptions,
    ) -> Result<FoldCurve, HbmError> {
        self.continue_fold_with(plane, None, start, up, opts)
    }

    /// [`Hbm::continue_fold`] with the second parameter the torque scale (`family` None) or the
    /// mechanism parameter p of `family` (`start` from [`Hbm::singular_at_with`]; `up` then
    /// means increasing p, and `opts.scales` is p's range).
    pub fn continue_fold_with(
        &mut self,
        plane: FoldPlane,
        family: Option<&MechanismFamily<'_>>,
        start: &FoldCurvePoint,
        up: bool,
        opts: &FoldCurveOptions,
    ) -> Result<FoldCurve, HbmError> {
        let m = self.unknowns();
        let x0 = self.unknowns_from(Some(&start.solution));
        let at0 = At { order: start.order, omega: start.omega, scale: start.scale };
        let p0 = family.map(|_| start.parameter);
        let mut walk = self.walk(plane, opts.test, family, &x0, &at0, p0)?;
        walk.plane.p_ref = start.omega;
        let mut y = DVector::zeros(m + 2);
        y.rows_mut(0, m).copy_from(&DVector::from_vec(x0));
        (y[m], y[m + 1]) = (walk.plane.lambda(&at0), walk.sigma(start.parameter));
        // The tangent at the start, oriented by the requested direction of the second parameter.
        let mut e_s = DVector::zeros(m + 2);
        e_s[m + 1] = if up { 1.0 } else { -1.0 };
        let (mut t, aug) = self.with_central(&mut walk, |h, w| h.fold_tangent(&y, w, &e_s))?;
        (walk.b, walk.c) = (aug.w.normalize(), aug.v.normalize());
        if t[m + 1] * e_s[m + 1] < 0.0 {
            t = -t;
        }
        let mut points = vec![start.clone()];
        let (mut cusps, mut scale_extrema) = (Vec::new(), Vec::new());
        let mut ds = opts.ds;
        let mut s_arc = 0.0;
        let inside = |walk: &Walk, y: &DVector<f64>| {
            let (at, _) = walk.at(y[m], y[m + 1]);
            let first = match plane {
                FoldPlane::Order => at.order,
                FoldPlane::Speed { .. } => at.omega,
                FoldPlane::Torque { .. } => at.scale,
            };
            (opts.range.0..=opts.range.1).contains(&first)
                && (opts.scales.0..=opts.scales.1).contains(&walk.second(y[m + 1]))
        };
        let end = loop {
            if points.len() >= opts.max_points {
                break FoldCurveEnd::MaxPoints;
            }
            if ds < opts.ds_min {
                break FoldCurveEnd::StepTooSmall;
            }
            let pred = &y + &t * ds;
            let Corrected { y: y_new, iterations: iters, skipped, lu, aug } =
                match self.fold_correct(&pred, &t, &mut walk, opts) {
                    Ok(r) => r,
                    Err(_) => {
                        ds *= 0.5;
                        continue;
                    }
                };
            // The tangent from the last Newton matrix, factorised at the iterate before the
            // converged one (within the tolerance of it): the predictor only needs it to that
            // accuracy, and a new matrix would cost three Jacobians. Turning points of the
            // second parameter are located with exact tangents (`locate_extremum`).
            let Some(mut t_new) = unit_tangent(&lu, &aug.bordered, m) else {
                ds *= 0.5;
                continue;
            };
            if t_new.dot(&t) < 0.0 {
                t_new = -t_new;
            }
            // A step whose tested block's null vector turned far has left the curve for a
            // neighbouring one (near a turning point in the second parameter the corrector can
            // land on another curve of the same test whose states are close): retry shorter.
            if t_new.dot(&t) < 0.95 || aug.v.normalize().dot(&walk.c).abs() < NULL_TURN {
                ds *= 0.5;
                continue;
            }
            (walk.b, walk.c) = (aug.w.normalize(), aug.v.normalize());
            let chord = (&y_new - &y).norm();
            if t[m + 1] * t_new[m + 1] < 0.0
                && let Some((p, tl)) = self.with_central(&mut walk, |h, w| h.locate_extremum(&y, &t, chord, w, opts))
            {
                // At the located point |dσ/dσ_arc| ≤ 1e-10; at a cusp dλ/dσ follows it to zero
                // (the paper's rotor: 2e-11), elsewhere it stays of order one.
                if tl.abs() <= 1e-6 { cusps.push(p) } else { scale_extrema.push(p) }
            }
            s_arc += chord;
            let x_new: Vec<f64> = y_new.rows(0, m).iter().copied().collect();
            let (at, p) = walk.at(y_new[m], y_new[m + 1]);
            let solution = problem(self, &mut walk.built, family, p)?.solution_from(&x_new, &at, iters);
            points.push(walk.point(&at, y_new[m + 1], s_arc, solution));
            (y, t) = (y_new, t_new);
            if !inside(&walk, &y) {
                break FoldCurveEnd::LeftBox;
            }
            // The step rule counts a settled iterate as taken, so the curve's resolution does
            // not depend on whether the last step was verified.
            let effort = iters + usize::from(skipped);
            if effort <= 3 {
                ds = (ds * 1.5).min(opts.ds_max);
            } else if effort >= 6 {
                ds *= 0.7;
            }
        };
        Ok(FoldCurve { points, cusps, scale_extrema, end })
    }

    /// The augmented system at y = (x, λ, σ).
    fn augmented_at(&mut self, y: &DVector<f64>, walk: &mut Walk) -> Result<Augmented, HbmError> {
        let m = self.unknowns();
        let x: Vec<f64> = y.rows(0, m).iter().copied().collect();
        let (at, p) = walk.at(y[m], y[m + 1]);
        self.augmented(&x, &at, p, walk)
    }

    /// The augmented Jacobian `[[J, ∂R̂/∂λ, ∂R̂/∂σ], [∂g/∂x, ∂g/∂λ, ∂g/∂σ]]` of `aug` bordered
    /// below by `row`, factorised whole.
    fn whole_newton(aug: &Augmented, row: &DVector<f64>) -> NewtonLu {
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
    fn with_central<R>(&mut self, walk: &mut Walk, f: impl FnOnce(&mut Self, &mut Walk) -> R) -> R {
        let before = std::mem::replace(&mut walk.central, true);
        let r = f(self, walk);
        walk.central = before;
        r
    }

    /// The unit tangent of the fold curve at y, oriented along `row`.
    fn fold_tangent(
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

    /// Newton's method on `R̂ = 0, g = 0, tᵀ(y − pred) = 0` from `pred`.
    fn fold_correct(
        &mut self,
        pred: &DVector<f64>,
        t: &DVector<f64>,
        walk: &mut Walk,
        opts: &FoldCurveOptions,
    ) -> Result<Corrected, HbmError> {
        let m = self.unknowns();
        let mut y = pred.clone();
        let mut previous = f64::INFINITY;
        let eliminate = walk.block.len() == m && walk.pinned.is_empty();
        for it in 1..=opts.max_iter {
            let aug = self.augmented_at(&y, walk)?;
            let lu = if eliminate {
                NewtonLu::eliminate(&aug, t).ok_or(HbmError::Singular { order: y[m] })?
            } else {
                Self::whole_newton(&aug, t)
            };
            let mut rhs = DVector::zeros(m + 2);
            rhs.rows_mut(0, m).copy_from(&aug.r);
            rhs[m] = aug.g;
            rhs[m + 1] = t.dot(&(&y - pred));
            let d = lu.solve(&rhs, &aug.bordered).ok_or(HbmError::Singular { order: y[m] })?;
            let step = d.amax();
            if !step.is_finite() || (y[m] - d[m]).is_nan() || y[m] - d[m] <= 0.0 {
                return Err(HbmError::NonFinite { order: y[m] });
            }
            y -= d;
            let skipped = step > opts.tol;
            if !skipped || settled(step, previous, opts.tol) {
                return Ok(Corrected { y, iterations: it, skipped, lu, aug });
            }
            previous = step;
        }
        Err(HbmError::NoConvergence { order: y[m], iterations: opts.max_iter, step: f64::NAN })
    }

    /// The extremum of the second parameter between y (tangent t) and the point a chord further
    /// on, where its rate along the curve changes sign: a secant (Illinois) search on the
    /// tangent's σ-component along the step. Returns the point and dλ/dσ there.
    fn locate_extremum(
        &mut self,
        y: &DVector<f64>,
        t: &DVector<f64>,
        chord: f64,
        walk: &mut Walk,
        opts: &FoldCurveOptions,
    ) -> Option<(ParameterPoint, f64)> {
        let m = self.unknowns();
        let slope = |this: &mut Self, walk: &mut Walk, sigma: f64| -> Option<(DVector<f64>, DVector<f64>)> {
            let pred = y + t * sigma;
            let yc = this.fold_correct(&pred, t, walk, opts).ok()?.y;
            let (mut tc, _) = this.fold_tangent(&yc, walk, t).ok()?;
            if tc.dot(t) < 0.0 {
                tc = -tc;
            }
            Some((tc, yc))
        };
        let f1 = slope(self, walk, chord)?.0[m + 1];
        let mut ill = Illinois::new((0.0, t[m + 1]), (chord, f1));
        let mut best = None;
        for _ in 0..60 {
            if ill.f1 == ill.f0 {
                break;
            }
            let s = ill.secant();
            let (tc, yc) = slope(self, walk, s)?;
            let f = tc[m + 1];
            let (at, _) = walk.at(yc[m], yc[m + 1]);
            let point =
                ParameterPoint { order: at.order, omega: at.omega, scale: at.scale, parameter: walk.second(yc[m + 1]) };
            best = Some((point, tc[m]));
            if f.abs() < 1e-10 || (ill.s1 - ill.s0).abs() < 1e-12 * chord.max(1e-300) {
                break;
            }
            ill.update(s, f);
        }
        best
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The block elimination solves the fold curve's Newton system as the whole (m + 2)-square
    /// LU does (the independent route), for a nearly singular J as at a fold (one singular
    /// value 1e-9) and for a regular one: agreement to 1e-12 of the solution's size.
    #[test]
    fn elimination_solves_the_whole_newton_system() {
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
