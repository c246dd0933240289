//! Free orbits by harmonic balance with a phase and an amplitude condition, unfolded by a
//! dissipation (and a mean torque with the rotor free), and the backbone through them by
//! natural continuation in the amplitude (the room's docs).

use crate::hbm::balance::{At, Hbm, HbmError, Parameter};
use crate::hbm::series::HbmSolution;
use nalgebra::{DMatrix, DVector};

/// Whether the rotor speed is prescribed or a degree of freedom during the free oscillation.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, serde::Serialize, serde::Deserialize, schemars::JsonSchema)]
pub enum FreeSpin {
    /// The spin speed is held at Ω (the rotor has infinite inertia): the pendulum's tuning order.
    #[default]
    Held,
    /// The rotor turns freely (no torque): the angular momentum is conserved and the order is
    /// the frequency over the rotor's mean speed.
    Free,
}

/// One free periodic orbit.
#[derive(Debug, Clone, PartialEq)]
pub struct FreeOrbit {
    /// Release amplitude A: the joint's coordinate at its turning point τ = 0 (rad, or m).
    pub amplitude: f64,
    /// Order of the free oscillation, ω₀/Ω.
    pub order: f64,
    /// The orbit: Fourier coefficients (solution's `order` = the free order, mean speed Ω).
    pub solution: HbmSolution,
    /// The unfolding dissipation ε at the solution (N·m·s/rad; zero on an exact orbit).
    pub dissipation: f64,
    /// The unfolding mean rotor torque at the solution, N·m (zero on an exact orbit; 0 with the
    /// spin held).
    pub mean_torque: f64,
    /// Newton iterations of the last solve.
    pub iterations: usize,
}

/// Settings of the backbone continuation.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct BackboneOptions {
    /// Largest amplitude step (the joint's unit).
    pub max_step: f64,
    /// Amplitude of the first orbit, solved from the linear mode (the joint's unit).
    pub start: f64,
    /// Newton tolerance on the step (max norm of the unknowns: rad, and the order).
    pub tol: f64,
    /// Newton iterations per solve.
    pub max_iter: usize,
}

impl Default for BackboneOptions {
    fn default() -> Self {
        Self { max_step: std::f64::consts::PI / 30.0, start: 0.01, tol: 1e-12, max_iter: 40 }
    }
}

/// The unknowns of the augmented system: the Fourier coefficients (the spin's gauge slot holds
/// the mean torque), the order and the dissipation.
#[derive(Debug, Clone)]
struct Point {
    x: Vec<f64>,
    order: f64,
    eps: f64,
}

impl Hbm {
    /// Per row i (u-space equation) and coordinate k, `∂q̇_k/∂u_i`: the generalized force of a
    /// unit viscous damper at k is `−q̇_k ∂q̇_k/∂u_i`.
    fn damper_map(&self) -> Vec<f64> {
        let n = self.n;
        let mut d = vec![0.0; n * n];
        let (mut e, mut qd) = (vec![0.0; n], vec![0.0; n]);
        for i in 0..n {
            e.fill(0.0);
            e[i] = 1.0;
            self.ev.speeds.qdot(&self.ev.parents, &e, &mut qd);
            d[i * n..(i + 1) * n].copy_from_slice(&qd);
        }
        d
    }

    /// The augmented residual and Jacobian at `p` (see the room's docs).
    fn free_system(
        &mut self,
        p: &Point,
        spin: FreeSpin,
        coord: usize,
        amplitude: f64,
        dmap: &[f64],
    ) -> (DVector<f64>, DMatrix<f64>) {
        let (n, nb, hh, s) = (self.n, self.nb, self.opts.harmonics, self.spin);
        let m = n * nb;
        let at = At { order: p.order, omega: self.omega, scale: 0.0 };
        self.assemble(&p.x, &at, Some(Parameter::Order));
        let w0 = self.ratio * p.order * self.omega;
        let mut r = DVector::zeros(m + 2);
        let mut j = DMatrix::zeros(m + 2, m + 2);
        r.rows_mut(0, m).copy_from(&self.rhat);
        j.view_mut((0, 0), (m, m)).copy_from(&self.jac);
        j.view_mut((0, m), (m, 1)).copy_from(&self.gp);
        // The unit dampers' term E = Σ_k D_ik ṗ_k, linear in the coefficients: ṗ_k has
        // cos hτ coefficient hω₀ b_kh and sin hτ coefficient −hω₀ a_kh.
        for i in 0..n {
            for k in (0..n).filter(|&k| k != s) {
                let d = dmap[i * n + k];
                if d == 0.0 {
                    continue;
                }
                for h in 1..=hh {
                    let hw = h as f64 * w0;
                    let (ca, cb) = (k * nb + 2 * h - 1, k * nb + 2 * h);
                    let (ra, rb) = (i * nb + 2 * h - 1, i * nb + 2 * h);
                    let (ec, es) = (d * hw * p.x[cb], -d * hw * p.x[ca]);
                    r[ra] += p.eps * ec;
                    r[rb] += p.eps * es;
                    // ∂/∂ε, ∂/∂n (∝ ω₀ ∝ n), ∂/∂x.
                    j[(ra, m + 1)] += ec;
                    j[(rb, m + 1)] += es;
                    j[(ra, m)] += p.eps * ec / p.order;
                    j[(rb, m)] += p.eps * es / p.order;
                    j[(ra, cb)] += p.eps * d * hw;
                    j[(rb, ca)] -= p.eps * d * hw;
                }
            }
        }
        if spin == FreeSpin::Held {
            // p_s ≡ 0 and no mean torque: the spin's rows become x = 0.
            for b in 0..nb {
                let row = s * nb + b;
                j.row_mut(row).fill(0.0);
                j[(row, row)] = 1.0;
                r[row] = p.x[row];
            }
        }
        // Phase: ṗ_j(0) = Σ h b_jh = 0. Amplitude: p_j(0) = a_j0 + Σ a_jh = A.
        let base = coord * nb;
        r[m] = (1..=hh).map(|h| h as f64 * p.x[base + 2 * h]).sum();
        r[m + 1] = p.x[base] + (1..=hh).map(|h| p.x[base + 2 * h - 1]).sum::<f64>() - amplitude;
        for h in 1..=hh {
            j[(m, base + 2 * h)] = h as f64;
            j[(m + 1, base + 2 * h - 1)] = 1.0;
        }
        j[(m + 1, base)] = 1.0;
        (r, j)
    }

    /// Newton's method on the augmented system from `guess`.
    fn free_newton(
        &mut self,
        guess: Point,
        spin: FreeSpin,
        coord: usize,
        amplitude: f64,
        opts: &BackboneOptions,
    ) -> Result<(Point, usize), HbmError> {
        let dmap = self.damper_map();
        let m = self.n * self.nb;
        let mut p = guess;
        let mut step = f64::INFINITY;
        for it in 1..=opts.max_iter {
            let (r, j) = self.free_system(&p, spin, coord, amplitude, &dmap);
            let dz = j.lu().solve(&r).ok_or(HbmError::Singular { order: p.order })?;
            step = dz.amax();
            if !step.is_finite() {
                return Err(HbmError::NonFinite { order: p.order });
            }
            for (xi, d) in p.x.iter_mut().zip(dz.rows(0, m).iter()) {
                *xi -= d;
            }
            p.order -= dz[m];
            p.eps -= dz[m + 1];
            if !(p.order.is_finite() && p.order > 0.0) {
                return Err(HbmError::NonFinite { order: p.order });
            }
            if step <= opts.tol {
                return Ok((p, it));
            }
        }
        Err(HbmError::NoConvergence { order: p.order, iterations: opts.max_iter, step })
    }

    /// The free periodic orbit of the joint with coordinate `coord` through its turning point at
    /// `amplitude`, by Newton's method from the orbit `from` (or, without one, from the linear
    /// mode: order `linear_order`, shape `shape` per coordinate, relative to the joint's = 1).
    /// `self` must be the unforced, undamped problem (the room's docs).
    pub fn free_orbit(
        &mut self,
        spin: FreeSpin,
        coord: usize,
        amplitude: f64,
        from: FreeStart<'_>,
        opts: &BackboneOptions,
    ) -> Result<FreeOrbit, HbmError> {
        if coord >= self.n || coord == self.spin {
            return Err(HbmError::Invalid(format!("coordinate {coord} is the spin's or out of range")));
        }
        if !(amplitude.is_finite() && amplitude != 0.0) {
            return Err(HbmError::Invalid(format!("amplitude must be finite and non-zero, got {amplitude}")));
        }
        let guess = match from {
            FreeStart::Linear { order, shape } => {
                let mut x = vec![0.0; self.n * self.nb];
                for (k, &c) in shape.iter().enumerate().take(self.n) {
                    if spin == FreeSpin::Free || k != self.spin {
                        x[k * self.nb + 1] = amplitude * c;
                    }
                }
                Point { x, order, eps: 0.0 }
            }
            FreeStart::Orbit(o) => self.point_of(o),
            FreeStart::Secant(a, b) => {
                let (pa, pb) = (self.point_of(a), self.point_of(b));
                let t = (amplitude - b.amplitude) / (b.amplitude - a.amplitude);
                Point {
                    x: pb.x.iter().zip(&pa.x).map(|(xb, xa)| xb + t * (xb - xa)).collect(),
                    order: pb.order + t * (pb.order - pa.order),
                    eps: 0.0,
                }
            }
        };
        let (p, iterations) = self.free_newton(guess, spin, coord, amplitude, opts)?;
        let at = At { order: p.order, omega: self.omega, scale: 0.0 };
        let solution = self.solution_from(&p.x, &at, iterations);
        let mean_torque = if spin == FreeSpin::Free { p.x[self.spin * self.nb] * self.t_scale } else { 0.0 };
        Ok(FreeOrbit { amplitude, order: p.order, solution, dissipation: p.eps, mean_torque, iterations })
    }

    fn point_of(&self, o: &FreeOrbit) -> Point {
        let mut x = self.unknowns_from(Some(&o.solution));
        x[self.spin * self.nb] = o.mean_torque / self.t_scale;
        Point { x, order: o.order, eps: o.dissipation }
    }

    /// The backbone of the joint with coordinate `coord`: the free orbit at each of `amplitudes`
    /// (any order, non-zero), by natural continuation from the linear mode (`linear_order`,
    /// `shape` as in [`Hbm::free_orbit`]); see the room's docs. One result per amplitude, in
    /// their order: an error where the continuation could not reach it.
    pub fn backbone(
        &mut self,
        spin: FreeSpin,
        coord: usize,
        linear_order: f64,
        shape: &[f64],
        amplitudes: &[f64],
        opts: &BackboneOptions,
    ) -> Vec<Result<FreeOrbit, HbmError>> {
        let mut out: Vec<Option<Result<FreeOrbit, HbmError>>> = vec![None; amplitudes.len()];
        for sign in [1.0f64, -1.0] {
            let mut idx: Vec<usize> = (0..amplitudes.len()).filter(|&i| amplitudes[i] * sign > 0.0).collect();
            idx.sort_by(|&a, &b| amplitudes[a].abs().total_cmp(&amplitudes[b].abs()));
            let Some(&first) = idx.first() else { continue };
            let start = sign * opts.start.min(amplitudes[first].abs());
            let lin = FreeStart::Linear { order: linear_order, shape };
            let mut prev: Vec<FreeOrbit> = Vec::new();
            let mut failed: Option<HbmError> = None;
            match self.free_orbit(spin, coord, start, lin, opts) {
                Ok(o) => prev.push(o),
                Err(e) => failed = Some(e),
            }
            for &i in &idx {
                if let Some(e) = &failed {
                    out[i] = Some(Err(e.clone()));
                    continue;
                }
                let target = amplitudes[i];
                let mut h = opts.max_step;
                while let Some(last) = prev.last() {
                    let gap = target - last.amplitude;
                    if gap.abs() <= 1e-15 * target.abs() {
                        break;
                    }
                    let a = last.amplitude + gap.signum() * gap.abs().min(h);
                    let from = match prev.len() {
                        1 => FreeStart::Orbit(last),
                        l => FreeStart::Secant(&prev[l - 2], last),
                    };
                    match self.free_orbit(spin, coord, a, from, opts) {
                        Ok(o) => {
                            prev.push(o);
                            if prev.len() > 2 {
                                prev.remove(0);
                            }
                        }
                        Err(e) => {
                            h *= 0.5;
                            if h < opts.max_step * 1e-3 {
                                failed = Some(e);
                                break;
                            }
                        }
                    }
                }
                out[i] = Some(match (&failed, prev.last()) {
                    (Some(e), _) => Err(e.clone()),
                    (None, Some(o)) => Ok(o.clone()),
                    (None, None) => Err(HbmError::Invalid("no orbit".into())),
                });
            }
        }
        out.into_iter().map(|r| r.unwrap_or_else(|| Err(HbmError::Invalid("zero amplitude".into())))).collect()
    }
}

/// Where [`Hbm::free_orbit`]'s Newton iteration starts.
#[derive(Debug, Clone, Copy)]
pub enum FreeStart<'a> {
    /// The linear mode: order, and the shape per coordinate relative to the joint's (= 1).
    Linear {
        /// The linear order of the mode.
        order: f64,
        /// Real mode shape per coordinate, the joint's entry 1.
        shape: &'a [f64],
    },
    /// A nearby orbit.
    Orbit(&'a FreeOrbit),
    /// The secant through two orbits, extrapolated to the new amplitude.
    Secant(&'a FreeOrbit, &'a FreeOrbit),
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::kane::Kane;

    /// The canonical CPVA without dampers and torques: the unforced, undamped problem at 1000 rpm.
    fn problem(harmonics: usize) -> Hbm {
        let mut mech = crate::cpva::CpvaParams::canonical().mechanism(None).unwrap();
        for j in &mut mech.joints {
            j.damper = 0.0;
        }
        mech.loads.ground_dampers.clear();
        mech.loads.joint_torques.clear();
        let kane = Kane::new(&mech).unwrap();
        let omega = crate::model::excitation::rpm_to_rad_s(1000.0);
        let opts = crate::hbm::balance::HbmOptions { harmonics, stability_samples: 0, ..Default::default() };
        Hbm::new(&kane, 0, omega, &[], opts).unwrap()
    }

    /// At held spin the pendulum is a plain pendulum: the order over n_t is π/(2K(sin(A/2)));
    /// with the rotor free the orbit conserves angular momentum, so the unfolding torque and
    /// dissipation come out zero.
    #[test]
    fn held_spin_orbit_is_the_pendulum_and_unfoldings_vanish() {
        let mut hbm = problem(20);
        let nt = 3.11;
        let a = 1.0f64;
        let opts = BackboneOptions::default();
        let o = hbm.backbone(FreeSpin::Held, 1, nt, &[0.0, 1.0], &[a], &opts).pop().unwrap().unwrap();
        let (mut x, mut y) = (1.0f64, (1.0f64 - (a / 2.0).sin().powi(2)).sqrt());
        // The AGM converges quadratically: 10 steps are past double precision.
        for _ in 0..10 {
            (x, y) = (0.5 * (x + y), (x * y).sqrt());
        }
        // π/(2K(k)) with K = π/(2 AGM(1, √(1 − k²))): the AGM itself.
        let ratio = x;
        assert!((o.order / nt - ratio).abs() < 1e-10, "{} vs {ratio}", o.order / nt);
        let f = hbm.backbone(FreeSpin::Free, 1, 3.19, &[0.0, 1.0], &[a], &opts).pop().unwrap().unwrap();
        assert!(f.mean_torque.abs() < 1e-9 && f.dissipation.abs() < 1e-9, "{} {}", f.mean_torque, f.dissipation);
        assert!(f.order > o.order);
    }
}
