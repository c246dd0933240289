//! The location of a crossing that is not a fold: bisection on the count of multipliers
//! outside the unit circle along its segment, then, for a branch point, the root of
//! det ∂R̂/∂x (a cubic through the determinant around the bracket), or on the cyclic route the
//! secant on a non-unison block's determinant.

use crate::hbm::balance::{Hbm, Parameter, Setup};
use crate::hbm::continuation::branch::{BifurcationKind, Branch};
use crate::hbm::numerics::{Factor, Illinois};
use crate::hbm::series::{HbmSolution, Stability};

impl Hbm {
    /// Locates each crossing that is not a fold by bisection along its segment: states from
    /// [`Branch::interpolate`] as guesses, solved at the fixed parameter (the segment holds no
    /// fold, so the parameter is monotone along it and the solve is regular), the count of
    /// multipliers outside the unit circle deciding the side, halved until 1e-11 of the
    /// parameter.
    /// A branch point (+1) is then finished by a secant search (Illinois) on the determinant of
    /// ∂R̂/∂x, which vanishes where the periodic problem has a second solution direction: its
    /// location is then limited by the corrector's tolerance, not by the monodromy's accuracy
    /// (~1e-7 in the multipliers, which moves a crossing by ~1e-6 in the order). A crossing
    /// whose bisection fails keeps its interpolated location; when the determinant keeps its sign
    /// (a multiplier repeated an even number of times by symmetry) the bisection's.
    pub(in crate::hbm::continuation) fn refine_crossings(&mut self, su: &Setup, branch: &mut Branch) {
        for k in 0..branch.bifurcations.len() {
            let i = branch.bifurcations[k].after;
            if branch.folds.iter().any(|f| f.after == i) {
                continue;
            }
            let Some(before) = branch.points[i].solution.stability.as_ref().map(Stability::outside) else { continue };
            if branch.bifurcations[k].kind == BifurcationKind::PlusOne
                && !self.non_unison.is_empty()
                && let Some((order, parameter)) = self.secant_on_block(su, branch, i)
            {
                let b = &mut branch.bifurcations[k];
                (b.order, b.parameter) = (order, parameter);
                continue;
            }
            let (mut lo, mut hi) = (0.0, 1.0);
            let mut found = None;
            // Halved until the bracket is 1e-11 of the parameter wide (a crossing to ≤ 1e-8
            // whatever the segment's length), 60 halvings at most.
            let width = (branch.points[i + 1].parameter - branch.points[i].parameter).abs();
            let target = 1e-11 * (1.0 + branch.points[i].parameter.abs());
            for _ in 0..60 {
                if (hi - lo) * width <= target {
                    break;
                }
                let mid = 0.5 * (lo + hi);
                let Some(guess) = branch.interpolate(i, mid) else { break };
                let lambda = su.param.value(&guess) / su.p_ref;
                let Ok(sol) = self.solve_within(&su.at(lambda), Some(&guess), self.stall_floor()) else { break };
                let Ok(st) = self.stability(&sol) else { break };
                if st.outside() == before {
                    lo = mid;
                } else {
                    hi = mid;
                }
                found = Some((sol.order, lambda * su.p_ref));
            }
            if branch.bifurcations[k].kind == BifurcationKind::PlusOne
                && found.is_some()
                && let Some(at) = self.root_of_determinant(su, branch, i, lo, hi)
            {
                found = Some(at);
            }
            if let Some((order, parameter)) = found {
                let b = &mut branch.bifurcations[k];
                (b.order, b.parameter) = (order, parameter);
            }
        }
    }

    /// The solution at fraction σ of segment i, solved at the interpolated parameter, and the
    /// sign and ln |·| of the determinant there of the whole ∂R̂/∂x (`block` None) or of the rows
    /// and columns of one non-unison set of the cyclic route (`block` Some(k): the Galerkin form
    /// of that set's variational equations with the parent held, whose determinant vanishes
    /// where its Floquet block has a multiplier +1).
    fn determinant_at(
        &mut self,
        su: &Setup,
        branch: &Branch,
        i: usize,
        sigma: f64,
        block: Option<usize>,
    ) -> Option<(HbmSolution, f64, f64)> {
        let guess = branch.interpolate(i, sigma)?;
        let lambda = su.param.value(&guess) / su.p_ref;
        let sol = self.solve_within(&su.at(lambda), Some(&guess), self.stall_floor()).ok()?;
        let x = self.unknowns_from(Some(&sol));
        self.assemble(&x, &su.at(lambda), Some(su.param));
        let (sign, log) = match block {
            None => self.factor(None).determinant(),
            Some(k) => {
                let nb = self.nb;
                let idx: Vec<usize> =
                    self.non_unison.get(k)?.coordinates.iter().flat_map(|&c| c * nb..(c + 1) * nb).collect();
                let matrix = nalgebra::DMatrix::from_fn(idx.len(), idx.len(), |r, c| self.jac[(idx[r], idx[c])]);
                Factor::Dense(matrix.lu()).determinant()
            }
        };
        log.is_finite().then_some((sol, sign, log))
    }

    /// A branch point of a non-unison set on the cyclic route: Illinois regula falsi along
    /// segment i on the determinant of the set's block of ∂R̂/∂x, when it changes sign between
    /// the segment's ends. The reduced problem itself stays regular there (the non-unison motion
    /// is not among its unknowns), so every solve converges and no Floquet analysis is needed:
    /// a few solves instead of the count's bisection. To 1e-12 of the segment or 40 solves.
    fn secant_on_block(&mut self, su: &Setup, branch: &Branch, i: usize) -> Option<(f64, f64)> {
        for k in 0..self.non_unison.len() {
            let (_, sa, la) = self.determinant_at(su, branch, i, 0.0, Some(k))?;
            let (_, sb, lb) = self.determinant_at(su, branch, i, 1.0, Some(k))?;
            if sa == sb {
                continue;
            }
            let reference = la.max(lb);
            let mut ill = Illinois::new((0.0, sa * (la - reference).exp()), (1.0, sb * (lb - reference).exp()));
            let mut best = None;
            for _ in 0..40 {
                if (ill.s1 - ill.s0).abs() <= 1e-12 || ill.f1 == ill.f0 {
                    break;
                }
                let s = ill.secant().clamp(ill.s0.min(ill.s1), ill.s0.max(ill.s1));
                let (sol, sg, lg) = self.determinant_at(su, branch, i, s, Some(k))?;
                best = Some((sol.order, su.param.value(&sol)));
                let f = sg * (lg - reference).exp();
                if f == 0.0 {
                    break;
                }
                ill.update(s, f);
            }
            if best.is_some() {
                return best;
            }
        }
        None
    }

    /// det ∂R̂/∂x at fraction σ of segment i (solved at the interpolated parameter), as a
    /// [`DetSample`].
    fn determinant_sample(&mut self, su: &Setup, branch: &Branch, i: usize, sigma: f64) -> Option<DetSample> {
        let (sol, sign, log) = self.determinant_at(su, branch, i, sigma, None)?;
        Some(DetSample { sigma, lambda: su.lambda(&sol), sign, log, order: sol.order })
    }

    /// A bracket [lo, hi] of segment i (fractions) across which det ∂R̂/∂x changes sign, grown
    /// from the multiplier count's bracket (lo, hi) when the determinant has one sign there: the
    /// count comes from the monodromy, whose error (~1e-7 in the multipliers) can put its
    /// crossing ~1e-6 in the order away from the determinant's root, and a bracket of 1e-11
    /// then misses it. The bracket grows fourfold on each side until one side changes sign (at
    /// most 24 times, to the segment's ends), then is shrunk by bisection back to the width it
    /// started with, or until a solve beside the root fails. Its two ends' samples; None when no
    /// sign change is found.
    fn determinant_bracket(
        &mut self,
        su: &Setup,
        branch: &Branch,
        i: usize,
        lo: f64,
        hi: f64,
    ) -> Option<(DetSample, DetSample)> {
        let (s_lo, s_hi) = (self.determinant_sample(su, branch, i, lo)?, self.determinant_sample(su, branch, i, hi)?);
        if s_lo.sign != s_hi.sign {
            return Some((s_lo, s_hi));
        }
        let sign = s_lo.sign;
        let w0 = (hi - lo).max(1e-14);
        let (mut a, mut b) = (s_lo, s_hi);
        let mut bracket = None;
        for k in 1..=24 {
            let w = w0 * 4f64.powi(k);
            let (na, nb) = ((lo - w).max(0.0), (hi + w).min(1.0));
            // A solve that fails (stalls right beside the root) leaves that side where it was:
            // the next, wider end brackets the root instead.
            for (end, held) in [(na, &mut a), (nb, &mut b)] {
                if end == held.sigma {
                    continue;
                }
                match self.determinant_sample(su, branch, i, end) {
                    Some(x) if x.sign != sign => {
                        bracket = Some(if end < held.sigma { (x, *held) } else { (*held, x) });
                        break;
                    }
                    Some(x) => *held = x,
                    None => {}
                }
            }
            if bracket.is_some() || (a.sigma <= 0.0 && b.sigma >= 1.0) {
                break;
            }
        }
        let (mut a, mut b) = bracket?;
        while b.sigma - a.sigma > w0 {
            // Right beside the root the solve may stall above its floor: the cubic through the
            // samples around the bracket reaches in from there.
            let Some(m) = self.determinant_sample(su, branch, i, 0.5 * (a.sigma + b.sigma)) else { break };
            if m.sign == a.sign {
                a = m;
            } else {
                b = m;
            }
        }
        Some((a, b))
    }

    /// det ∂R̂/∂x = 0 near [lo, hi] of segment i (a bracket of the multiplier count's
    /// bisection, moved to the determinant's own sign change by [`Hbm::determinant_bracket`]):
    /// the cubic through the determinant at lo, hi and one bracket width beyond each,
    /// as a function of the parameter, and its root in the bracket; the order and parameter
    /// there. Newton at fixed parameter does not converge to 1e-10 right at the branch point (its
    /// Jacobian is singular there), so the determinant is sampled where it does and interpolated
    /// in between: over a bracket of ~1e-6 of the segment it is linear to many digits. None when
    /// no sign change is found near the bracket, or a solve at a node fails.
    fn root_of_determinant(&mut self, su: &Setup, branch: &Branch, i: usize, lo: f64, hi: f64) -> Option<(f64, f64)> {
        let (s_lo, s_hi) = self.determinant_bracket(su, branch, i, lo, hi)?;
        let (lo, hi) = (s_lo.sigma, s_hi.sigma);
        let w = hi - lo;
        // Two nodes beside the bracket, inside the segment and distinct from the bracket's ends
        // (clamping lo − w or hi + w to the segment's end repeated a node, and the cubic through
        // a repeated node is not defined).
        let mut samples = vec![s_lo, s_hi];
        for sigma in [lo - w, hi + w, lo - 2.0 * w, hi + 2.0 * w, lo + w / 3.0, lo + 2.0 * w / 3.0]
            .into_iter()
            .filter(|s| (0.0..=1.0).contains(s))
            .take(2)
        {
            samples.push(self.determinant_sample(su, branch, i, sigma)?);
        }
        if samples.len() < 4 {
            return None;
        }
        samples.sort_by(|x, y| x.sigma.total_cmp(&y.sigma));
        let (l_lo, l_hi) = (s_lo.lambda, s_hi.lambda);
        if samples.windows(2).any(|p| p[0].lambda == p[1].lambda) {
            return None;
        }
        // Values relative to the largest magnitude, so that the interpolation sees O(1) numbers.
        let reference = samples.iter().map(|x| x.log).fold(f64::NEG_INFINITY, f64::max);
        let pts: Vec<(f64, f64)> = samples.iter().map(|x| (x.lambda, x.sign * (x.log - reference).exp())).collect();
        let cubic = |l: f64| {
            pts.iter()
                .enumerate()
                .map(|(k, &(lk, fk))| {
                    fk * pts
                        .iter()
                        .enumerate()
                        .filter(|&(j, _)| j != k)
                        .map(|(_, &(lj, _))| (l - lj) / (lk - lj))
                        .product::<f64>()
                })
                .sum::<f64>()
        };
        let (mut a, mut b) = (l_lo, l_hi);
        let fa = cubic(a);
        if fa.signum() == cubic(b).signum() {
            return None;
        }
        for _ in 0..100 {
            let mid = 0.5 * (a + b);
            if cubic(mid).signum() == fa.signum() {
                a = mid;
            } else {
                b = mid;
            }
        }
        let lambda = 0.5 * (a + b);
        // The order: n itself on an order branch, the fixed order otherwise.
        let order = if su.param == Parameter::Order { lambda } else { s_lo.order };
        Some((order, lambda * su.p_ref))
    }
}

/// det ∂R̂/∂x at fraction `sigma` of a segment: the scaled parameter λ of the state solved there,
/// the determinant's sign and ln |det|, and the order.
#[derive(Debug, Clone, Copy)]
struct DetSample {
    sigma: f64,
    lambda: f64,
    sign: f64,
    log: f64,
    order: f64,
}
