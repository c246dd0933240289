//! The data model of a harmonic-balance solution branch in its continued [`Parameter`] (order
//! n, mean speed Ω or torque scale s): the points with the quantities of the paper's figures and the
//! branch tangent, the folds (turning points in the parameter, where a sweep jumps: Figs. 3, 4),
//! the Floquet bifurcations (multiplier crossings of the unit circle between successive points,
//! classified by the critical multiplier: +1, −1, or a complex pair for Neimark–Sacker), and the
//! read-outs of a [`Branch`]: starting guesses at a parameter value and cubic Hermite
//! interpolation between points.

use crate::hbm::balance::Parameter;
use crate::hbm::series::HbmSolution;
use std::f64::consts::PI;
/// One point of a branch, with the quantities of the paper's figures.
#[derive(Debug, Clone, PartialEq)]
pub struct BranchPoint {
    /// Excitation order n.
    pub order: f64,
    /// Value of the continued parameter: the order n, the mean speed Ω (rad/s) or the torque
    /// scale s.
    pub parameter: f64,
    /// Arclength from the first point (chord sum).
    pub arclength: f64,
    /// dλ/ds: the parameter component of the unit tangent (its sign change marks a fold).
    pub slope: f64,
    /// dn/ds on an order branch (equal to `slope`), 0 on the others (the order is fixed).
    pub order_slope: f64,
    /// Amplitude of the spin body's angular acceleration at the main order n, rad/s².
    pub accel_main: f64,
    /// The same at the second order 2n, rad/s².
    pub accel_second: f64,
    /// Largest peak amplitude of the non-spin coordinates (the pendulum angle φ), rad.
    pub pendulum_amplitude: f64,
    /// Floquet verdict (None when stability was not computed).
    pub stable: Option<bool>,
    /// The full solution.
    pub solution: HbmSolution,
    /// Derivatives along the branch (per unit of `arclength`) of the solution's Fourier
    /// coefficients (layout of [`HbmSolution::coefficients`], rad), of its mean torque (N·m) and
    /// of the continued parameter (its units): the branch tangent, for [`Branch::interpolate`].
    /// Empty when not known (a refined fold).
    pub d_coefficients: Vec<f64>,
    /// See `d_coefficients`: d T_m / ds, N·m.
    pub d_mean_torque: f64,
    /// See `d_coefficients`: d parameter / ds.
    pub d_parameter: f64,
}

/// Direction of the turn at a fold.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum FoldKind {
    /// The branch reaches its largest parameter value and turns back (an up-sweep jumps here).
    Maximum,
    /// The branch reaches its smallest parameter value and turns back (a down-sweep jumps here).
    Minimum,
}

/// A turning point of the branch in the continued parameter.
#[derive(Debug, Clone, PartialEq)]
pub struct Fold {
    /// Order at the fold (refined when
    /// [`ContinuationOptions::refine_folds`](crate::hbm::ContinuationOptions::refine_folds); the fixed
    /// order when another parameter is continued).
    pub order: f64,
    /// Value of the continued parameter at the fold (n, Ω in rad/s, or s).
    pub parameter: f64,
    /// Which way the branch turns.
    pub kind: FoldKind,
    /// Index of the branch point just before the fold.
    pub after: usize,
    /// Main-order rotor acceleration at the fold, rad/s².
    pub accel_main: f64,
    /// Pendulum peak amplitude at the fold, rad.
    pub pendulum_amplitude: f64,
    /// The motion the branch takes through the fold: its tangent there in the layout of
    /// [`HbmSolution::coefficients`](crate::hbm::HbmSolution::coefficients) (the gauge slot zero), which at
    /// a turning point spans the Jacobian's null space, i.e. the critical mode (whether the
    /// absorbers turn together or apart). Empty when the fold was not refined.
    pub critical: Vec<f64>,
}

/// How a branch loses or gains stability (by the critical Floquet multiplier).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum BifurcationKind {
    /// A real multiplier through +1 (a fold, or a symmetry-breaking pitchfork).
    PlusOne,
    /// A real multiplier through −1 (period doubling).
    PeriodDoubling,
    /// A complex pair through the unit circle (Neimark–Sacker: quasi-periodic motion).
    NeimarkSacker,
}

/// What a bifurcation is, by the branch's geometry and the crossing multiplier: a +1 crossing is
/// a fold when the parameter turns back there, otherwise a branch point (another branch crosses:
/// symmetry breaking, such as the loss of unison of identical absorbers, or a transcritical
/// point).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum BifurcationClass {
    /// A turning point of the parameter (a jump of a sweep).
    Fold,
    /// A +1 crossing where the parameter goes on: another branch crosses this one.
    BranchPoint,
    /// A real multiplier through −1: a branch of period-doubled motions starts.
    PeriodDoubling,
    /// A complex pair through the unit circle: quasi-periodic motions start.
    NeimarkSacker,
}

impl BifurcationClass {
    /// The class in words, for summaries.
    pub fn words(self) -> &'static str {
        match self {
            BifurcationClass::Fold => "fold",
            BifurcationClass::BranchPoint => "branch point",
            BifurcationClass::PeriodDoubling => "period doubling",
            BifurcationClass::NeimarkSacker => "Neimark–Sacker",
        }
    }
}

/// A crossing of the unit circle by Floquet multipliers between two successive branch points.
#[derive(Debug, Clone, PartialEq)]
pub struct Bifurcation {
    /// Index of the point before the change.
    pub after: usize,
    /// Order at the crossing: the fold's at a fold; otherwise located by bisection along the
    /// segment (with [`ContinuationOptions::refine_folds`](crate::hbm::ContinuationOptions::refine_folds)),
    /// else interpolated where the crossing multiplier's modulus passes 1.
    pub order: f64,
    /// The continued parameter at the crossing, found the same way.
    pub parameter: f64,
    /// The kind, by the argument of the critical multiplier on the unstable side.
    pub kind: BifurcationKind,
    /// Fold or branch point (for +1), period doubling or Neimark–Sacker.
    pub class: BifurcationClass,
    /// True when the branch becomes stable at this change (in the direction of the branch).
    pub gains_stability: bool,
    /// Number of multipliers outside the unit circle after the change (0: stable).
    pub unstable_after: usize,
}

/// Why the continuation stopped.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum BranchEnd {
    /// Reached the target value (the last point is at it exactly).
    ReachedTarget,
    /// Turned back and left the range at the starting value (the last point is at it).
    LeftRange,
    /// Hit [`ContinuationOptions::max_points`](crate::hbm::ContinuationOptions::max_points).
    MaxPoints,
    /// The step fell below [`ContinuationOptions::ds_min`](crate::hbm::ContinuationOptions::ds_min) (the
    /// last point is the last success).
    StepTooSmall,
    /// Passed [`ContinuationOptions::deadline`](crate::hbm::ContinuationOptions::deadline): the
    /// analysis overran its time budget (the last point is the last success).
    Watchdog,
    /// A switched branch ([`Hbm::switch_at`](crate::hbm::Hbm::switch_at)) returned to the symmetric
    /// (unison) states: the last point is where it meets them, a branch point of the symmetric
    /// branch.
    Unison,
}

/// A solution branch.
#[derive(Debug, Clone, PartialEq)]
pub struct Branch {
    /// The continued parameter.
    pub parameter: Parameter,
    /// The points in the order of the arclength.
    pub points: Vec<BranchPoint>,
    /// Turning points in the parameter.
    pub folds: Vec<Fold>,
    /// Multiplier crossings of the unit circle (when stability was computed).
    pub bifurcations: Vec<Bifurcation>,
    /// Why the continuation stopped.
    pub end: BranchEnd,
    /// Total Newton iterations (correctors and fold refinement).
    pub newton_iterations: usize,
}

impl Branch {
    /// Starting guesses at parameter value p (the order n of an order branch): for each segment
    /// of the branch that crosses p, the solution at its nearer end (pass it to [`Hbm::solve`](crate::hbm::Hbm::solve)
    /// there; one per sheet of an S-shaped branch).
    pub fn guesses_at(&self, value: f64) -> Vec<&HbmSolution> {
        self.points
            .windows(2)
            .filter(|w| (w[0].parameter - value) * (w[1].parameter - value) <= 0.0)
            .map(|w| {
                if (w[0].parameter - value).abs() <= (w[1].parameter - value).abs() {
                    &w[0].solution
                } else {
                    &w[1].solution
                }
            })
            .collect()
    }

    /// The state at fraction `sigma` ∈ [0, 1] of the segment from point `i` to point `i + 1`, by
    /// cubic Hermite interpolation in arclength of the Fourier coefficients, the mean torque and
    /// the parameter, with the branch tangents as end slopes. The error is fourth order in the
    /// step, so a few interpolated states per segment draw a branch smoothly where the amplitudes
    /// change fast between the solved points (near an antiresonance, where a harmonic's
    /// coefficients pass close to zero, its amplitude has a sharp minimum). Not a solution of the
    /// equations: `residual` is NaN, `stability` None, `iterations` 0. Falls back to linear
    /// interpolation when a tangent is unknown. None when `i + 1` is not a point.
    pub fn interpolate(&self, i: usize, sigma: f64) -> Option<HbmSolution> {
        let (a, b) = (self.points.get(i)?, self.points.get(i + 1)?);
        let h = b.arclength - a.arclength;
        let s = sigma.clamp(0.0, 1.0);
        let (s2, s3) = (s * s, s * s * s);
        // Hermite basis: values at the ends, slopes (per unit σ, i.e. h·d/ds) at the ends.
        let (h00, h10, h01, h11) = (2.0 * s3 - 3.0 * s2 + 1.0, s3 - 2.0 * s2 + s, 3.0 * s2 - 2.0 * s3, s3 - s2);
        let hermite = h > 0.0
            && a.d_coefficients.len() == a.solution.coefficients.len()
            && b.d_coefficients.len() == a.d_coefficients.len();
        let mix = |y0: f64, y1: f64, d0: f64, d1: f64| {
            if hermite { h00 * y0 + h10 * h * d0 + h01 * y1 + h11 * h * d1 } else { y0 + s * (y1 - y0) }
        };
        let (ca, cb) = (&a.solution.coefficients, &b.solution.coefficients);
        if ca.len() != cb.len() {
            return None;
        }
        let coefficients = (0..ca.len())
            .map(|j| {
                let (d0, d1) = if hermite { (a.d_coefficients[j], b.d_coefficients[j]) } else { (0.0, 0.0) };
                mix(ca[j], cb[j], d0, d1)
            })
            .collect();
        let p = mix(a.parameter, b.parameter, a.d_parameter, b.d_parameter);
        let mut sol = HbmSolution {
            coefficients,
            mean_torque: mix(a.solution.mean_torque, b.solution.mean_torque, a.d_mean_torque, b.d_mean_torque),
            iterations: 0,
            residual: f64::NAN,
            stability: None,
            ..a.solution.clone()
        };
        match self.parameter {
            Parameter::Order => sol.order = p,
            Parameter::Speed { .. } => sol.omega = p,
            Parameter::TorqueScale { .. } => sol.torque_scale = p,
        }
        // ω₀ is a fixed multiple of nΩ.
        sol.base_frequency = a.solution.base_frequency / (a.solution.order * a.solution.omega) * sol.order * sol.omega;
        sol.top_harmonic_ratio = sol.harmonic_ratio();
        sol.needs_more_harmonics = a.solution.needs_more_harmonics || b.solution.needs_more_harmonics;
        sol.coupling_tail = a.solution.coupling_tail.max(b.solution.coupling_tail);
        Some(sol)
    }
}

/// Multiplier crossings of the unit circle between successive points: wherever the number of
/// multipliers outside it changes, so a second crossing on an already unstable branch (say a
/// symmetry-breaking one on the middle sheet of N pendulums) is reported too, not only the
/// changes of the stable/unstable verdict.
///
/// The crossing multiplier is, on the side with more multipliers outside, the outside one
/// nearest the circle; its argument gives the kind (0: +1, π: −1, else a complex pair). A real
/// multiplier through +1 in the step that holds a fold is the fold itself (the Jacobian of the
/// periodic problem is singular there, so the monodromy has the eigenvalue 1): it takes the
/// fold's refined location. Elsewhere the location is interpolated linearly where the modulus
/// of the crossing multiplier (matched across the step by distance) passes 1.
pub(super) fn bifurcations(points: &[BranchPoint], folds: &[Fold]) -> Vec<Bifurcation> {
    let mut out = Vec::new();
    for (i, w) in points.windows(2).enumerate() {
        let (Some(a), Some(b)) = (&w[0].solution.stability, &w[1].solution.stability) else { continue };
        let (na, nb) = (a.outside(), b.outside());
        if na == nb {
            continue;
        }
        let (more, fewer) = if na > nb { (a, b) } else { (b, a) };
        let Some(mu) = more.multipliers.iter().filter(|m| m.norm() > 1.0).min_by(|x, y| x.norm().total_cmp(&y.norm()))
        else {
            continue;
        };
        let kind = if mu.im.abs() < 1e-9 * mu.norm() || mu.arg().abs() < 0.02 {
            if mu.re > 0.0 { BifurcationKind::PlusOne } else { BifurcationKind::PeriodDoubling }
        } else if (mu.arg().abs() - PI).abs() < 0.02 {
            BifurcationKind::PeriodDoubling
        } else {
            BifurcationKind::NeimarkSacker
        };
        let partner = fewer.multipliers.iter().min_by(|x, y| (*x - mu).norm().total_cmp(&(*y - mu).norm()));
        let (m_more, m_fewer) = (mu.norm(), partner.map_or(1.0, |p| p.norm()));
        let (ma, mb) = if na > nb { (m_more, m_fewer) } else { (m_fewer, m_more) };
        let f = if mb != ma { ((1.0 - ma) / (mb - ma)).clamp(0.0, 1.0) } else { 0.5 };
        let fold = folds.iter().find(|fd| fd.after == i).filter(|_| kind == BifurcationKind::PlusOne);
        let (order, parameter) = match fold {
            Some(fd) => (fd.order, fd.parameter),
            _ => (w[0].order + f * (w[1].order - w[0].order), w[0].parameter + f * (w[1].parameter - w[0].parameter)),
        };
        let class = match kind {
            BifurcationKind::PlusOne if fold.is_some() => BifurcationClass::Fold,
            BifurcationKind::PlusOne => BifurcationClass::BranchPoint,
            BifurcationKind::PeriodDoubling => BifurcationClass::PeriodDoubling,
            BifurcationKind::NeimarkSacker => BifurcationClass::NeimarkSacker,
        };
        out.push(Bifurcation {
            after: i,
            order,
            parameter,
            kind,
            class,
            gains_stability: b.stable && !a.stable,
            unstable_after: nb,
        });
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::hbm::series::Stability;
    use approx::abs_diff_eq;
    use nalgebra::Complex;

    /// A branch point at order n with the given multipliers (the rest of the solution is inert).
    fn point(n: f64, multipliers: &[Complex<f64>]) -> BranchPoint {
        let max_modulus = multipliers.iter().map(|m| m.norm()).fold(0.0, f64::max);
        let stability =
            Stability { multipliers: multipliers.to_vec(), max_modulus, stable: max_modulus < 1.0, blocks: Vec::new() };
        let solution = HbmSolution {
            order: n,
            omega: 100.0,
            torque_scale: 1.0,
            base_frequency: 100.0 * n,
            harmonics: 1,
            spin: 0,
            rotation: vec![1.0],
            coefficients: vec![0.0; 3],
            mean_torque: 0.0,
            iterations: 0,
            residual: 0.0,
            top_harmonic_ratio: 0.0,
            coupling_tail: 0.0,
            needs_more_harmonics: false,
            stability: Some(stability),
        };
        BranchPoint {
            order: n,
            parameter: n,
            arclength: n,
            slope: 1.0,
            order_slope: 1.0,
            accel_main: 0.0,
            accel_second: 0.0,
            pendulum_amplitude: 0.0,
            stable: Some(max_modulus < 1.0),
            solution,
            d_coefficients: Vec::new(),
            d_mean_torque: 0.0,
            d_parameter: 0.0,
        }
    }

    /// Each kind of crossing, placed where the crossing multiplier's modulus passes 1, and a
    /// second real multiplier through +1 on an already unstable stretch (no verdict change,
    /// still reported); a +1 crossing in a step with a fold takes the fold's location.
    #[test]
    fn crossings_are_classified_located_and_counted() {
        let c = |re: f64, im: f64| Complex::new(re, im);
        let r = |m: f64| c(m, 0.0);
        let pol = |m: f64, a: f64| Complex::from_polar(m, a);
        let points = vec![
            point(3.00, &[r(0.9), r(0.5)]),
            point(3.01, &[r(1.1), r(0.5)]),  // +1 crossing at 3.005
            point(3.02, &[r(1.3), r(0.95)]), // none
            point(3.03, &[r(1.3), r(1.05)]), // second +1 crossing at 3.025, still unstable
            point(3.04, &[r(0.8), r(0.7)]),  // both back inside: one report, stable after
            point(3.05, &[r(-0.96), r(0.2)]),
            point(3.06, &[r(-1.04), r(0.2)]), // period doubling at 3.055
            point(3.07, &[pol(0.98, 1.0), pol(0.98, -1.0)]),
            point(3.08, &[pol(1.02, 1.1), pol(1.02, -1.1)]), // −1 back inside, then Neimark–Sacker at 3.075
        ];
        let b = bifurcations(&points, &[]);
        let kinds: Vec<_> = b.iter().map(|x| (x.after, x.kind, x.unstable_after)).collect();
        assert_eq!(
            kinds,
            vec![
                (0, BifurcationKind::PlusOne, 1),
                (2, BifurcationKind::PlusOne, 2),
                (3, BifurcationKind::PlusOne, 0),
                (5, BifurcationKind::PeriodDoubling, 1),
                (6, BifurcationKind::PeriodDoubling, 0),
                (7, BifurcationKind::NeimarkSacker, 2),
            ]
        );
        for (x, at) in b.iter().zip([3.005, 3.025, f64::NAN, 3.055, f64::NAN, 3.075]) {
            if at.is_finite() {
                assert!(abs_diff_eq!(x.order, at, epsilon = 1e-12), "{:?} at {} not {at}", x.kind, x.order);
            }
        }
        assert!(b[2].gains_stability && !b[0].gains_stability && !b[1].gains_stability);
        // With a fold in the first step, the +1 crossing sits at the fold.
        let fold = Fold {
            order: 3.0071,
            parameter: 3.0071,
            kind: FoldKind::Maximum,
            after: 0,
            accel_main: 0.0,
            pendulum_amplitude: 0.0,
            critical: Vec::new(),
        };
        assert_eq!(bifurcations(&points, &[fold])[0].order, 3.0071);
    }
}
