//! [`RoutedHbm`]: a problem with its route chosen, which on the cyclic route solves the reduced
//! mechanism and expands every solution, branch and tangent to the full one, and restricts
//! every full-size guess to the representatives.

use super::detect::{Route, route_for};
use super::reduce::{Reduction, reduce};
use crate::hbm::balance::{Hbm, HbmError, HbmOptions, Parameter, PointHook};
use crate::hbm::continuation::{Branch, ContinuationOptions};
use crate::hbm::series::{HbmSolution, Stability};
use crate::kane::Kane;
use crate::model::excitation::Harmonic;

/// A harmonic-balance problem with its route chosen ([`detect`](super::detect::detect)): on the cyclic route the
/// problem solved is the reduced mechanism's, and every solution, branch and stability verdict
/// returned is the full mechanism's (the room's docs); on the general route it is [`Hbm`] itself.
#[derive(Debug, Clone)]
pub struct RoutedHbm {
    hbm: Hbm,
    route: Route,
    reduction: Option<Reduction>,
}

impl RoutedHbm {
    /// [`Hbm::with_speed_forcing`] on the route [`detect`](super::detect::detect) chooses for `kane`'s mechanism: the
    /// same arguments, in the full mechanism's joint numbering.
    pub fn new(
        kane: &Kane,
        spin_joint: usize,
        omega: f64,
        forcing: (&[Harmonic], &[Harmonic]),
        inputs: &[(usize, f64, f64)],
        options: HbmOptions,
    ) -> Result<Self, HbmError> {
        let mech = kane.mechanism();
        let input_joints: Vec<usize> = inputs.iter().map(|i| i.0).collect();
        let route = route_for(kane, spin_joint, &input_joints);
        let Route::Cyclic { sets } = &route else {
            return Self::general(kane, spin_joint, omega, forcing, inputs, options, route);
        };
        let red = reduce(mech, kane.joint_torques(), sets);
        let rkane = Kane::new(&red.mech).map_err(|e| HbmError::Invalid(format!("reduced mechanism: {e}")))?;
        let rinputs: Vec<(usize, f64, f64)> = inputs.iter().map(|&(j, s, p)| (red.joint_map[j], s, p)).collect();
        let mut hbm =
            Hbm::with_speed_forcing(&rkane, red.joint_map[spin_joint], omega, forcing.0, forcing.1, &rinputs, options)?;
        hbm.non_unison = red.non_unison.clone();
        Ok(Self { hbm, route, reduction: Some(red) })
    }

    /// The general route, whatever the mechanism (the reference), with `route` as its report.
    fn general(
        kane: &Kane,
        spin_joint: usize,
        omega: f64,
        forcing: (&[Harmonic], &[Harmonic]),
        inputs: &[(usize, f64, f64)],
        options: HbmOptions,
        route: Route,
    ) -> Result<Self, HbmError> {
        let hbm = Hbm::with_speed_forcing(kane, spin_joint, omega, forcing.0, forcing.1, inputs, options)?;
        Ok(Self { hbm, route, reduction: None })
    }

    /// The general route forced (the reference the cyclic route is checked against).
    pub fn new_general(
        kane: &Kane,
        spin_joint: usize,
        omega: f64,
        forcing: (&[Harmonic], &[Harmonic]),
        inputs: &[(usize, f64, f64)],
        options: HbmOptions,
    ) -> Result<Self, HbmError> {
        let route = Route::General { reason: "requested".into() };
        Self::general(kane, spin_joint, omega, forcing, inputs, options, route)
    }

    /// The route taken.
    pub fn route(&self) -> &Route {
        &self.route
    }

    /// The problem actually solved: the reduced mechanism's on the cyclic route (its solutions
    /// are reduced-size; prefer the methods of [`RoutedHbm`]).
    pub fn hbm(&self) -> &Hbm {
        &self.hbm
    }

    /// The problem actually solved, to continue or analyse it further (fold and unison-loss
    /// curves in two parameters, the fold-curves room): its states are the reduced mechanism's on the
    /// cyclic route.
    pub fn hbm_mut(&mut self) -> &mut Hbm {
        &mut self.hbm
    }

    /// Sets the torque scale s of the fixed-parameter solves ([`Hbm::set_torque_scale`]).
    pub fn set_torque_scale(&mut self, scale: f64) -> Result<(), HbmError> {
        self.hbm.set_torque_scale(scale)
    }

    /// Sets the mean speed Ω of the fixed-parameter solves, rad/s ([`Hbm::set_speed`]).
    pub fn set_speed(&mut self, omega: f64) -> Result<(), HbmError> {
        self.hbm.set_speed(omega)
    }

    /// [`Hbm::solve`] on the route; `guess` and the result are full-size (a guess is read in
    /// unison, by each set's representative, on the cyclic route).
    pub fn solve(&mut self, order: f64, guess: Option<&HbmSolution>) -> Result<HbmSolution, HbmError> {
        let guess = guess.map(|g| self.restrict(g));
        let sol = self.hbm.solve(order, guess.as_ref())?;
        Ok(self.expand(sol))
    }

    /// [`Hbm::stability`] of a full-size solution (in unison on the cyclic route): on the cyclic
    /// route its blocks are the unison one and one per set, each with its multiplicity.
    pub fn stability(&mut self, sol: &HbmSolution) -> Result<Stability, HbmError> {
        if !self.in_unison(sol) {
            return Err(HbmError::Invalid(
                "cyclic route: the solution is not in unison (its stability needs the general route)".into(),
            ));
        }
        let sol = self.restrict(sol);
        self.hbm.stability(&sol)
    }

    /// Whether every member of each set has its representative's coefficients (to 1e-12 rad
    /// relative to the largest coefficient); always true on the general route.
    fn in_unison(&self, sol: &HbmSolution) -> bool {
        let Some(red) = &self.reduction else { return true };
        let nb = 2 * sol.harmonics + 1;
        if sol.coefficients.len() != red.coord_map.len() * nb {
            return true;
        }
        let scale = sol.coefficients.iter().fold(0.0f64, |m, v| m.max(v.abs()));
        red.coord_map.iter().enumerate().all(|(c, &r)| {
            let rep = red.coord_back[r];
            (0..nb).all(|h| (sol.coefficients[c * nb + h] - sol.coefficients[rep * nb + h]).abs() <= 1e-12 * scale)
        })
    }

    /// [`Hbm::continue_in`] on the route, the branch full-size.
    pub fn continue_in(
        &mut self,
        parameter: Parameter,
        from: f64,
        to: f64,
        guess: Option<&HbmSolution>,
        copts: &ContinuationOptions,
    ) -> Result<Branch, HbmError> {
        let guess = guess.map(|g| self.restrict(g));
        let mut b = self.hbm.continue_in(parameter, from, to, guess.as_ref(), copts)?;
        if self.reduction.is_some() {
            for p in &mut b.points {
                p.solution = self.expand(std::mem::replace(&mut p.solution, empty()));
                if !p.d_coefficients.is_empty() {
                    p.d_coefficients = self.expand_coefficients(&p.d_coefficients, p.solution.harmonics);
                }
            }
            let harmonics = b.points.first().map_or(0, |p| p.solution.harmonics);
            for f in &mut b.folds {
                if !f.critical.is_empty() {
                    f.critical = self.expand_coefficients(&f.critical, harmonics);
                }
            }
        }
        Ok(b)
    }

    /// [`Hbm::set_on_point`] on the problem solved (the reduced one on the cyclic route).
    pub fn set_on_point(&mut self, hook: Option<PointHook>) {
        self.hbm.set_on_point(hook);
    }

    /// [`RoutedHbm::continue_in`] in the order.
    pub fn continue_in_order(
        &mut self,
        n_from: f64,
        n_to: f64,
        guess: Option<&HbmSolution>,
        copts: &ContinuationOptions,
    ) -> Result<Branch, HbmError> {
        self.continue_in(Parameter::Order, n_from, n_to, guess, copts)
    }

    /// Full-size coefficients (per full coordinate, `2H + 1` each) from reduced ones.
    fn expand_coefficients(&self, reduced: &[f64], harmonics: usize) -> Vec<f64> {
        let Some(red) = &self.reduction else { return reduced.to_vec() };
        let nb = 2 * harmonics + 1;
        red.coord_map.iter().flat_map(|&r| reduced[r * nb..(r + 1) * nb].iter().copied()).collect()
    }

    /// The full mechanism's solution from the reduced one's (the room's docs, item 1).
    fn expand(&self, sol: HbmSolution) -> HbmSolution {
        let Some(red) = &self.reduction else { return sol };
        let coefficients = self.expand_coefficients(&sol.coefficients, sol.harmonics);
        let spin = red.coord_back[sol.spin];
        let rotation = red.coord_map.iter().map(|&r| sol.rotation[r]).collect();
        HbmSolution { coefficients, spin, rotation, ..sol }
    }

    /// The reduced problem's solution read from a full one (each set by its representative).
    fn restrict(&self, sol: &HbmSolution) -> HbmSolution {
        let Some(red) = &self.reduction else { return sol.clone() };
        let nb = 2 * sol.harmonics + 1;
        if sol.coefficients.len() != red.coord_map.len() * nb {
            // Not the full mechanism's: passed on for Hbm's own check to name.
            return sol.clone();
        }
        let coefficients =
            red.coord_back.iter().flat_map(|&c| sol.coefficients[c * nb..(c + 1) * nb].iter().copied()).collect();
        let rotation = red.coord_back.iter().map(|&c| sol.rotation[c]).collect();
        HbmSolution { coefficients, spin: red.coord_map[sol.spin], rotation, ..sol.clone() }
    }
}

/// A placeholder while a point's solution is expanded in place.
fn empty() -> HbmSolution {
    HbmSolution {
        order: 0.0,
        omega: 0.0,
        torque_scale: 0.0,
        base_frequency: 0.0,
        harmonics: 0,
        spin: 0,
        rotation: Vec::new(),
        coefficients: Vec::new(),
        mean_torque: 0.0,
        iterations: 0,
        residual: 0.0,
        top_harmonic_ratio: 0.0,
        coupling_tail: 0.0,
        needs_more_harmonics: false,
        stability: None,
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::model::excitation::rpm_to_rad_s;
    use crate::model::speeds::Speeds;

    /// The structure the non-unison block rests on (the room's docs, item 2), read from the general
    /// problem's per-sample A, B, C at a unison solution of three pendulums, for both speed
    /// choices: a pendulum's rows have no entry in another pendulum's columns, every pendulum
    /// has the same diagonal block, and the rotor's row has the same entry in every pendulum's
    /// column (it sees their sum). The cross entries are exactly zero (a pendulum's row does not
    /// read another's coordinates); the equal ones differ by the rounding of the central
    /// differences (ε/h ≈ 1e-10 times the row's terms, measured ≤ 1.3e-9 of the largest entry
    /// with joint rates): bound 1e-8 of the largest entry.
    #[test]
    fn members_couple_only_through_the_sum_the_parent_sees() {
        for speeds in [Speeds::AbsoluteAngularVelocities, Speeds::JointRates] {
            let mut mech = crate::cpva::CpvaParams::canonical().with_pendulums(3).mechanism(None).unwrap();
            mech.speeds = speeds;
            let kane = Kane::new(&mech).unwrap();
            let h = [Harmonic { multiple: 1.0, amplitude: 200.0, phase: 0.0 }];
            let mut hbm = Hbm::new(&kane, 0, rpm_to_rad_s(1000.0), &h, HbmOptions::default()).unwrap();
            let sol = hbm.solve(3.05, None).unwrap();
            hbm.stability(&sol).unwrap();
            let n = hbm.n;
            let nn = n * n;
            let largest = hbm.samples.iter().fold(0.0f64, |m, v| m.max(v.abs()));
            let tol = 1e-8 * largest;
            let mut worst = 0.0f64;
            for abc in hbm.samples.chunks_exact(3 * nn) {
                for m in abc.chunks_exact(nn) {
                    let e = |i: usize, k: usize| m[i * n + k];
                    for j in 1..n {
                        for k in 1..n {
                            assert!(j == k || e(j, k) == 0.0, "{speeds:?}: entry ({j}, {k}) = {:e}", e(j, k));
                        }
                        worst = worst.max((e(j, j) - e(1, 1)).abs());
                        worst = worst.max((e(0, j) - e(0, 1)).abs());
                        worst = worst.max((e(j, 0) - e(1, 0)).abs());
                    }
                }
            }
            assert!(worst <= tol, "{speeds:?}: {worst:e} of {largest:e}");
        }
    }
}
