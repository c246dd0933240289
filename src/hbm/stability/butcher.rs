//! Butcher's seven-stage sixth-order Runge–Kutta method (its tableau and one period of the
//! variational equations by it), its stability function against RK4 with Richardson's
//! extrapolation, and the step count that makes it no less accurate on the mechanism's fastest
//! mode (Dahlquist's test equation).

use super::dense::row;
use nalgebra::Complex;
use std::f64::consts::PI;

/// Margin on the fastest rate of the mechanism linearised about its steady spin: the
/// variational equations of a periodic orbit have their coefficients varying about those, and
/// Butcher's error grows as the seventh power of the rate.
const RATE_MARGIN: f64 = 1.5;

/// Butcher's method is taken when its error on the fastest mode is at most this fraction of
/// RK4 with Richardson's.
const BUTCHER6_SHARE: f64 = 0.5;

/// The number of steps in which Butcher's sixth-order method integrates the variational
/// equations over a period T = `period` no less accurately than RK4 with Richardson's
/// extrapolation at N_s = `ns` samples (steps 2T/N_s and 4T/N_s), and with fewer derivative
/// evaluations (7 a step against 3N_s in all); None when no such count exists.
///
/// The two are compared on the test equation `y' = λy` (Dahlquist's; E. Hairer and G. Wanner,
/// *Solving Ordinary Differential Equations II*, §IV.2) for a mode of modulus |λ| = `rate`
/// (times [`RATE_MARGIN`]) at angles from the imaginary axis (an undamped oscillation) to the
/// negative real axis (a pure decay): a method's error over the period is about its number of
/// steps times `|R(hλ) − e^{hλ}|`, R its stability function. Butcher's method must be within
/// [`BUTCHER6_SHARE`] of the other's error (or below 1e-13, rounding) and never above 1e-6, and
/// it starts from N_s/4 steps, RK4's coarse step, which resolves the coefficients' harmonics as
/// that route does. Butcher's R leaves the unit disc on the imaginary axis (|R(iy)| > 1 for
/// y ≳ 0.5) and grows fast beyond |hλ| ≈ 2.5, where RK4's still damps: a stiff shaft then
/// makes the error test fail and the caller keeps RK4 with Richardson.
pub(super) fn butcher6_steps(rate: f64, period: f64, ns: usize) -> Option<usize> {
    let rt = RATE_MARGIN * rate * period;
    if !(rt.is_finite() && rt >= 0.0) {
        return None;
    }
    let error = |steps: usize, r: fn(Complex<f64>) -> Complex<f64>| {
        (0..=4)
            .map(|k| {
                let z = Complex::from_polar(rt / steps as f64, PI * (0.5 + k as f64 / 8.0));
                steps as f64 * (r(z) - z.exp()).norm()
            })
            .fold(0.0, f64::max)
    };
    let coarse = (ns / 4).max(1);
    let bound = (BUTCHER6_SHARE * error(coarse, rk4_richardson_amplification)).clamp(1e-13, 1e-6);
    let mut steps = coarse;
    while 7 * steps < 3 * ns {
        if error(steps, butcher6_amplification) <= bound {
            return Some(steps);
        }
        steps += (steps / 16).max(1);
    }
    None
}

/// Butcher's method's stability function R(z), one step of `y' = λy` at `z = hλ` (from the
/// tableau: stage i is `1 + z Σ_j a_ij Y_j`, `R = 1 + z Σ_i b_i Y_i`).
fn butcher6_amplification(z: Complex<f64>) -> Complex<f64> {
    let mut y = [Complex::new(0.0, 0.0); 7];
    for i in 0..7 {
        y[i] = Complex::new(1.0, 0.0) + z * (0..i).map(|j| y[j] * BUTCHER6_A[i][j]).sum::<Complex<f64>>();
    }
    Complex::new(1.0, 0.0) + z * y.iter().zip(&BUTCHER6_B).map(|(y, b)| y * b).sum::<Complex<f64>>()
}

/// RK4 with Richardson's extrapolation over one coarse step `z = hλ`: `(16 R(z/2)² − R(z))/15`,
/// R RK4's stability function `1 + z + z²/2 + z³/6 + z⁴/24`.
fn rk4_richardson_amplification(z: Complex<f64>) -> Complex<f64> {
    let r = |z: Complex<f64>| 1.0 + z * (1.0 + z * (0.5 + z * (1.0 / 6.0 + z / 24.0)));
    let half = r(z / 2.0);
    (16.0 * half * half - r(z)) / 15.0
}

/// Nodes of Butcher's seven-stage, sixth-order explicit Runge–Kutta method in sixths of a step
/// (c = 0, 1/3, 2/3, 1/3, 1/2, 1/2, 1), its coefficients a_ij (row i: the stage's combination of
/// the earlier stages) and its weights b (J. C. Butcher, *Numerical Methods for Ordinary
/// Differential Equations*, 2nd ed., Wiley 2008, §325; order checked by a unit test).
pub(super) const BUTCHER6_C: [usize; 7] = [0, 2, 4, 2, 3, 3, 6];
const BUTCHER6_A: [[f64; 6]; 7] = [
    [0.0; 6],
    [1.0 / 3.0, 0.0, 0.0, 0.0, 0.0, 0.0],
    [0.0, 2.0 / 3.0, 0.0, 0.0, 0.0, 0.0],
    [1.0 / 12.0, 1.0 / 3.0, -1.0 / 12.0, 0.0, 0.0, 0.0],
    [-1.0 / 16.0, 9.0 / 8.0, -3.0 / 16.0, -3.0 / 8.0, 0.0, 0.0],
    [0.0, 9.0 / 8.0, -3.0 / 8.0, -3.0 / 4.0, 1.0 / 2.0, 0.0],
    [9.0 / 44.0, -9.0 / 11.0, 63.0 / 44.0, 18.0 / 11.0, 0.0, -16.0 / 11.0],
];
const BUTCHER6_B: [f64; 7] = [11.0 / 120.0, 0.0, 27.0 / 40.0, 27.0 / 40.0, -4.0 / 15.0, -4.0 / 15.0, 11.0 / 120.0];

/// Butcher's sixth-order method (`BUTCHER6_*`) for `Φ' = 𝒜(t) Φ` over one period T from `phi` in
/// `steps` steps of T/steps; the coefficients are read on a grid of six instants per step
/// (`at(6·step + c)`, c as `BUTCHER6_C`, past the period wrapping around). `deriv` as in
/// [`rk4_period`](super::dense::rk4_period). Inlined, so that it takes the target features of its caller.
#[inline(always)]
pub(super) fn rk6_period<'a, C: ?Sized + 'a>(
    mut phi: Vec<f64>,
    steps: usize,
    period: f64,
    at: impl Fn(usize) -> &'a C,
    deriv: impl Fn(&C, &Vec<f64>, &mut Vec<f64>),
) -> Vec<f64> {
    let h = period / steps as f64;
    let mut k: [Vec<f64>; 7] = std::array::from_fn(|_| phi.clone());
    let mut tmp = phi.clone();
    for step in 0..steps {
        for (i, (&c, a)) in BUTCHER6_C.iter().zip(&BUTCHER6_A).enumerate() {
            let (done, rest) = k.split_at_mut(i);
            if i == 0 {
                deriv(at(6 * step + c), &phi, &mut rest[0]);
                continue;
            }
            tmp.copy_from_slice(&phi);
            for (kj, &aij) in done.iter().zip(a) {
                if aij != 0.0 {
                    row(&mut tmp, kj, h * aij);
                }
            }
            deriv(at(6 * step + c), &tmp, &mut rest[0]);
        }
        for (kj, &bj) in k.iter().zip(&BUTCHER6_B) {
            if bj != 0.0 {
                row(&mut phi, kj, h * bj);
            }
        }
    }
    phi
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The step rule on the test equation: N_s/4 steps where the fastest mode is slow against
    /// the period (Butcher's error there is a third of RK4 with Richardson's: `y = 0.1` on the
    /// imaginary axis, the two stability functions' distances from `e^{iy}` 6.6e-11 and 2.3e-10,
    /// computed apart); a few more steps where it is faster; RK4 with Richardson past the point
    /// where Butcher's method would need 3N_s/7 steps; and each answer meets the rule's own
    /// bounds, recomputed here from the stability functions' closed forms (Taylor polynomials
    /// of e^z plus Butcher's z⁷ coefficient bᵀA⁶1).
    #[test]
    fn butcher6_steps_follow_the_fastest_rate() {
        let (period, ns) = (1.0, 256);
        // y = 0.1 at 64 steps with the margin.
        assert_eq!(butcher6_steps(6.4 / RATE_MARGIN, period, ns), Some(64));
        assert_eq!(butcher6_steps(0.0, period, ns), Some(64));
        assert_eq!(butcher6_steps(f64::NAN, period, ns), None);
        assert_eq!(butcher6_steps(f64::INFINITY, period, ns), None);
        let faster = butcher6_steps(20.0 / RATE_MARGIN, period, ns).unwrap();
        assert!(faster > 64 && 7 * faster < 3 * ns, "{faster}");
        assert_eq!(butcher6_steps(200.0, period, ns), None);
        // The stability functions against their closed forms: RK4's Taylor polynomial, and
        // Butcher's, `R(z) = 1 + Σ_k z^{k+1} bᵀAᵏ1` (a Neumann series; A is strictly lower
        // triangular), which is e^z's Taylor polynomial to z⁶ (order six) plus `bᵀA⁶1 z⁷`.
        let mut power = [1.0; 7];
        for _ in 0..6 {
            let next: Vec<f64> = (0..7).map(|i| (0..6).map(|j| BUTCHER6_A[i][j] * power[j]).sum()).collect();
            power.copy_from_slice(&next);
        }
        let c7: f64 = BUTCHER6_B.iter().zip(&power).map(|(b, p)| b * p).sum();
        for z in [Complex::new(0.0, 0.3), Complex::new(-0.2, 0.5), Complex::new(-1.0, 0.0)] {
            let taylor =
                |k: usize| (0..=k).map(|m| z.powu(m as u32) / (1..=m).product::<usize>() as f64).sum::<Complex<f64>>();
            let r6 = taylor(6) + c7 * z.powu(7);
            assert!((butcher6_amplification(z) - r6).norm() <= 1e-14, "{z}");
            let r4 = |z: Complex<f64>| {
                (0..=4).map(|m| z.powu(m as u32) / (1..=m).product::<usize>() as f64).sum::<Complex<f64>>()
            };
            let rich = (16.0 * r4(z / 2.0) * r4(z / 2.0) - r4(z)) / 15.0;
            assert!((rk4_richardson_amplification(z) - rich).norm() <= 1e-14, "{z}");
        }
        println!("Butcher's z⁷ coefficient {c7:.6e} (e^z's 1/5040 = {:.6e})", 1.0 / 5040.0);
    }

    /// Butcher's method has order six on a linear system with time-varying, non-commuting
    /// coefficients: Mathieu's equation `x'' + 0.1 x' + (1 + 0.8 cos t) x = 0` over its period
    /// 2π, against the same method at 1024 steps. Halving the step must divide the error by
    /// 2⁶ = 64, RK4's 16 (measured: 47–63 per halving from 8 to 256 steps, approaching 64; the
    /// order fitted over 16 → 128 steps 5.8). The tableau also satisfies the 37 order conditions
    /// of the rooted trees up to order six exactly (checked apart in rational arithmetic).
    #[test]
    fn butcher6_has_order_six() {
        let period = 2.0 * PI;
        // [K | L] of x'' = −K x − L x' on a grid of six instants per step.
        let phi = |steps: usize| {
            let grid: Vec<[f64; 2]> =
                (0..6 * steps).map(|j| [1.0 + 0.8 * (period * j as f64 / (6 * steps) as f64).cos(), 0.1]).collect();
            let deriv = |kl: &[f64; 2], p: &Vec<f64>, out: &mut Vec<f64>| {
                out[0] = p[2];
                out[1] = p[3];
                out[2] = -kl[0] * p[0] - kl[1] * p[2];
                out[3] = -kl[0] * p[1] - kl[1] * p[3];
            };
            let at = |j: usize| &grid[j % (6 * steps)];
            rk6_period(vec![1.0, 0.0, 0.0, 1.0], steps, period, at, deriv)
        };
        let exact = phi(2048);
        let error = |steps: usize| phi(steps).iter().zip(&exact).map(|(a, b)| (a - b).abs()).fold(0.0, f64::max);
        for steps in [8, 16, 32, 64, 128] {
            println!("{steps} steps: error {:.3e}, halved {:.2}", error(steps), error(steps) / error(2 * steps));
        }
        let order = (error(16) / error(128)).log2() / 3.0;
        assert!((order - 6.0).abs() < 0.3, "{order}");
    }
}
