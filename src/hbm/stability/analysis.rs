//! The Floquet analysis of a solution: the per-sample derivatives of its last Jacobian turned
//! into the variational equations' coefficients, the monodromy by the dense route (small
//! blocks, and each non-unison block of the cyclic route) or by the tree route (the whole of a
//! large mechanism), the multipliers without the cyclic spin angle's trivial +1, and the
//! senses of the complex pairs near ±1.

use super::butcher::butcher6_steps;
use super::dense::{monodromy, solve_in_place};
use super::eigen::{HessenbergLu, eigen, is_hessenberg};
use super::tree::TreeScheme;
use crate::hbm::balance::{At, Hbm, HbmError, HbmOptions, Parameter};
use crate::hbm::series::{FloquetBlock, HbmSolution, PairSense, Stability};
use crate::kane::Kane;
use crate::model::excitation::Harmonic;
use nalgebra::{Complex, DMatrix, DVector};
use std::f64::consts::PI;

impl Hbm {
    /// Floquet multipliers of a solution of this problem (see the stability room's docs): monodromy by RK4 with Richardson's extrapolation over the variational
    /// equations with [`HbmOptions::stability_samples`] samples per period (beyond six
    /// coordinates by Butcher's sixth-order method from a quarter as many steps where the
    /// mechanism's fastest rate allows; the room's docs). One block (`all`) on the
    /// general route; on the reduced problem of the cyclic route ([`RoutedHbm`](crate::hbm::RoutedHbm)) the
    /// `unison` block and one non-unison block per identical set, each from its own monodromy.
    pub fn stability(&mut self, sol: &HbmSolution) -> Result<Stability, HbmError> {
        let ns = self.opts.stability_samples;
        let order = sol.order;
        if ns == 0 {
            return Err(HbmError::Invalid("stability_samples is 0: stability disabled".into()));
        }
        if sol.ndof() != self.n || sol.spin != self.spin {
            return Err(HbmError::Invalid("solution belongs to another mechanism or spin joint".into()));
        }
        // Per-sample derivatives at this solution (reused when the last Jacobian was assembled
        // there, as in the continuation), interpolated to the N_s stability samples.
        let x = self.unknowns_from(Some(sol));
        let at = At { order, omega: sol.omega, scale: sol.torque_scale };
        let same = |(xs, o): &(Vec<f64>, At)| {
            *o == at && xs.iter().zip(&x).all(|(a, b)| (a - b).abs() <= 1e-14 * (1.0 + b.abs()))
        };
        if !self.samples_at.as_ref().is_some_and(same) {
            self.assemble(&x, &at, Some(Parameter::Order));
        }
        let period = 2.0 * PI / sol.base_frequency;
        let all: Vec<usize> = (0..self.n).collect();
        self.pair_senses.clear();
        // The cyclic spin angle's trivial +1 is not a physical multiplier; with gravity the spin
        // angle is a state like the others.
        let drop = self.cyclic.then_some(self.spin);
        let scheme = Some(self.tree_scheme(period, sol.omega));
        let multipliers = self.block_multipliers(&all, drop, order, period, scheme)?;
        if self.non_unison.is_empty() {
            return Ok(Stability::from_blocks(vec![FloquetBlock {
                label: "all".into(),
                multiplicity: 1,
                multipliers,
            }]));
        }
        // A reduced problem of the cyclic route: its own multipliers are the unison ones; each
        // identical set adds its representative's block with the parent held, once per
        // non-zero wavenumber (the cyclic room).
        let mut blocks = vec![FloquetBlock { label: "unison".into(), multiplicity: 1, multipliers }];
        for set in self.non_unison.clone() {
            let multipliers = self.block_multipliers(&set.coordinates, None, order, period, scheme)?;
            blocks.push(FloquetBlock { label: set.label, multiplicity: set.multiplicity, multipliers });
        }
        Ok(Stability::from_blocks(blocks))
    }

    /// The Floquet multipliers of the variational equations restricted to the coordinates
    /// `coords` (rows and columns of A, B, C at the samples of the last assembly; the other
    /// coordinates held at zero deviation), by decreasing modulus, without the state of the
    /// coordinate `drop` (the cyclic spin angle). `coords` must be an invariant set of the
    /// variational equations for the result to be multipliers of the whole problem: all
    /// coordinates, or a member of an identical set under non-unison motion. `tree`: the
    /// integration of the tree route where it applies (all of more than six coordinates); None
    /// takes the dense route always.
    fn block_multipliers(
        &mut self,
        coords: &[usize],
        drop: Option<usize>,
        order: f64,
        period: f64,
        tree: Option<TreeScheme>,
    ) -> Result<Vec<Complex<f64>>, HbmError> {
        let ns = self.opts.stability_samples;
        let (nf, nb) = (self.n, coords.len());
        let nt = self.aft.nt;
        let nn = nf * nf;
        // Beyond the fixed-size sizes, the whole mechanism by its tree (see `tree_monodromy`).
        if let Some(scheme) = tree
            && nb == nf
            && 2 * nb > 12
            && let Some(phi) = self.tree_monodromy(period, scheme)
        {
            let drop_at = drop.and_then(|k| coords.iter().position(|&c| c == k));
            let (multipliers, reduced) =
                finish(phi, 2 * nb, drop_at, self.rotation_to_drop(coords, drop).as_deref(), order)?;
            self.pair_senses.push(pair_senses(&reduced, &multipliers, nb, drop_at));
            return Ok(multipliers);
        }
        // [K | L] = C⁻¹ [A | B] at the N_t samples, stored as 2n² series of N_t values (entry
        // (i, c) of the n × 2n block is series i·2n + c), n = coords.len().
        let m2 = 2 * nb * nb;
        let mut kl = vec![0.0; m2 * nt];
        let mut ck = vec![0.0; m2];
        let mut c = vec![0.0; nb * nb];
        for j in 0..nt {
            let abc = &self.samples[j * 3 * nn..(j + 1) * 3 * nn];
            for (i, &ri) in coords.iter().enumerate() {
                for (k, &ck_) in coords.iter().enumerate() {
                    ck[i * 2 * nb + k] = abc[ri * nf + ck_];
                    ck[i * 2 * nb + nb + k] = abc[nn + ri * nf + ck_];
                    c[i * nb + k] = abc[2 * nn + ri * nf + ck_];
                }
            }
            if !solve_in_place(&mut c, &mut ck, nb, 2 * nb) {
                return Err(HbmError::Singular { order });
            }
            for (e, &v) in ck.iter().enumerate() {
                kl[e * nt + j] = v;
            }
        }
        // Each series interpolated to the N_s stability instants (one forward FFT of N_t and one
        // inverse of N_s), then regrouped per instant: sys[j] = [K | L] at instant j.
        let mut spec = vec![Default::default(); self.aft.half_len()];
        let mut up = vec![0.0; ns];
        let mut sys = vec![0.0; ns * m2];
        for e in 0..m2 {
            self.aft.spectrum(&kl[e * nt..(e + 1) * nt], &mut spec);
            self.upsampler.run(&spec, nt, &mut up);
            for (j, &v) in up.iter().enumerate() {
                sys[j * m2 + e] = v;
            }
        }
        let phi = monodromy(&sys, nb, ns, period);
        let rotation = self.rotation_to_drop(coords, drop);
        let drop_at = drop.and_then(|k| coords.iter().position(|&c| c == k));
        let (multipliers, reduced) = finish(phi, 2 * nb, drop_at, rotation.as_deref(), order)?;
        self.pair_senses.push(pair_senses(&reduced, &multipliers, nb, drop_at));
        Ok(multipliers)
    }

    /// The tree route's integration for a solution of period `period` at the mean speed
    /// `omega`: Butcher's sixth-order method where [`butcher6_steps`] finds it no less accurate
    /// on the mechanism's fastest mode than RK4 with Richardson's extrapolation and cheaper,
    /// that route otherwise (and when the fastest rate is unknown).
    fn tree_scheme(&self, period: f64, omega: f64) -> TreeScheme {
        // Centrifugal stiffness grows as Ω², so a rate linearised at Ω₀ grows at most as Ω/Ω₀;
        // shafts' and gears' rates do not grow.
        let rate = self.tree_rate.map(|(rate, omega0)| rate * (omega.abs() / omega0.abs()).max(1.0));
        rate.and_then(|r| butcher6_steps(r, period, self.opts.stability_samples))
            .map_or(TreeScheme::Rk4Richardson, |steps| TreeScheme::Butcher6 { steps })
    }

    /// The rigid rotation over `coords` when the dropped state is the spin angle and joints turn
    /// with it through meshes (then the trivial +1 belongs to the shift along it, not to the
    /// spin angle alone); None when the spin angle alone is that shift.
    fn rotation_to_drop(&self, coords: &[usize], drop: Option<usize>) -> Option<Vec<f64>> {
        drop?;
        let z: Vec<f64> = coords.iter().map(|&c| self.rotation[c]).collect();
        z.iter().zip(coords).any(|(&z, &c)| c != self.spin && z != 0.0).then_some(z)
    }
}

/// The multipliers of a d × d monodromy (row-major), without the state at `drop` (the cyclic
/// spin angle), by decreasing modulus, and the matrix they are the eigenvalues of. With a rigid
/// rotation z over the angles (the first d/2 states) the trivial +1 has the eigenvector `[z; 0]`:
/// Φ is first taken to the coordinates `p = q − z q_drop` (`Φ' = (I − N) Φ (I + N)`,
/// `N = (z − e_drop) e_dropᵀ`), in which that eigenvector is the unit vector of the dropped
/// state.
fn finish(
    phi: Vec<f64>,
    d: usize,
    drop: Option<usize>,
    rotation: Option<&[f64]>,
    order: f64,
) -> Result<(Vec<Complex<f64>>, Reduced), HbmError> {
    let mut phi = DMatrix::from_row_slice(d, d, &phi);
    if phi.iter().any(|v| !v.is_finite()) {
        return Err(HbmError::NonFinite { order });
    }
    if let (Some(p), Some(z)) = (drop, rotation) {
        let mut zs = DVector::zeros(d);
        zs.rows_mut(0, z.len()).copy_from(&DVector::from_row_slice(z));
        let col = &phi * zs;
        phi.set_column(p, &col);
        let row = phi.row(p).clone_owned();
        for (j, &zj) in z.iter().enumerate() {
            if j != p && zj != 0.0 {
                let r = phi.row(j) - &row * zj;
                phi.set_row(j, &r);
            }
        }
    }
    let (reduced, dim) = match drop {
        Some(p) => (phi.remove_row(p).remove_column(p), d - 1),
        None => (phi, d),
    };
    let (mut multipliers, schur) = eigen(reduced.clone()).ok_or(HbmError::Eigen { order, dim })?;
    multipliers.sort_by(|a, b| b.norm().total_cmp(&a.norm()));
    // The dense systems' pair vectors come from a dense LU (`pair_senses`): at their sizes it
    // costs less than taking the Schur form's factors to complex numbers.
    let schur = schur.filter(|_| dim > SCHUR_PAIRS_FROM);
    Ok((multipliers, Reduced { matrix: reduced, schur }))
}

/// Beyond this dimension of the reduced monodromy (the fixed-size dense route's largest, 12)
/// the pairs' eigenvectors are found on the Schur form.
const SCHUR_PAIRS_FROM: usize = 12;

/// The reduced monodromy whose eigenvalues are the multipliers, with its real Schur form
/// `Q T Qᵀ` when nalgebra's converged (T quasi-upper-triangular, so upper Hessenberg).
struct Reduced {
    matrix: DMatrix<f64>,
    schur: Option<(DMatrix<f64>, DMatrix<f64>)>,
}

/// Pairs closer to ±1 than this are given their sense (a cheap screen: the eigenvector is only
/// needed where a pair may pass through ±1 within one step).
const PAIR_NEAR: f64 = 0.5;

/// The complex pairs among `multipliers` (eigenvalues of `reduced`, the monodromy of a block of
/// `nb` coordinates in the states (angles, rates) with the angle at `drop` removed) within
/// [`PAIR_NEAR`] of +1 or −1, each with its eigenvector by inverse iteration (two solves with
/// the shifted matrix, whose factorisation is the whole cost) and its sense. With the Schur form
/// the iteration runs on T, whose Hessenberg pattern factorises in O(d²) instead of O(d³), and
/// the vector is taken back by Q.
///
/// NOTE: the dense complex LU per pair was ≈ 8 % of the 16-pendulum branches (15 pairs near +1
/// in one 33 × 33 block at every point); the Schur vectors come with the eigenvalues anyway.
fn pair_senses(reduced: &Reduced, multipliers: &[Complex<f64>], nb: usize, drop: Option<usize>) -> Vec<PairSense> {
    let schur = reduced.schur.as_ref().filter(|(_, t)| is_hessenberg(t));
    let reduced = &reduced.matrix;
    let d = reduced.nrows();
    let index = |k: usize, rate: bool| -> usize {
        let i = if rate { nb + k } else { k };
        match drop {
            Some(p) if i > p => i - 1,
            _ => i,
        }
    };
    let mut out = Vec::new();
    for &mu in multipliers {
        if mu.im <= 1e-12 * mu.norm() {
            continue;
        }
        let side = if mu.re < 0.0 { -1.0 } else { 1.0 };
        if (mu - side).norm() >= PAIR_NEAR {
            continue;
        }
        // Shifted off the eigenvalue so that the factorisation stays finite; the solve's growth
        // along the eigenvector is then ~1/shift, far above every other direction's.
        let shift = mu + Complex::new(1e-10, 1e-10) * (1.0 + mu.norm());
        let ones = DVector::from_element(d, Complex::new(1.0, 0.0));
        let v = match schur.and_then(|(q, t)| HessenbergLu::new(t, shift).map(|lu| (q, lu))) {
            Some((q, lu)) => {
                let qc = q.map(|x| Complex::new(x, 0.0));
                let w = inverse_iteration(|v| lu.solve(v), qc.tr_mul(&ones));
                &qc * w
            }
            None => {
                let a = DMatrix::from_fn(d, d, |i, j| {
                    Complex::new(reduced[(i, j)], 0.0) - if i == j { shift } else { Complex::new(0.0, 0.0) }
                });
                let lu = a.lu();
                inverse_iteration(|v| lu.solve(v), ones)
            }
        };
        let (mut cross, mut nq, mut nu) = (0.0, 0.0, 0.0);
        for k in (0..nb).filter(|&k| Some(k) != drop) {
            let (q, u) = (v[index(k, false)], v[index(k, true)]);
            cross += (q.conj() * u).im;
            nq += q.norm_sqr();
            nu += u.norm_sqr();
        }
        let sense = cross / (nq * nu).sqrt();
        if sense.is_finite() {
            out.push(PairSense { side, sense, v });
        }
    }
    out
}

/// Two steps of inverse iteration from `v` with the shifted matrix's solve, normalised; the last
/// finite iterate.
fn inverse_iteration(
    solve: impl Fn(&DVector<Complex<f64>>) -> Option<DVector<Complex<f64>>>,
    mut v: DVector<Complex<f64>>,
) -> DVector<Complex<f64>> {
    for _ in 0..2 {
        let Some(w) = solve(&v) else { break };
        let norm = w.norm();
        if !(norm.is_finite() && norm > 0.0) {
            break;
        }
        v = w / Complex::new(norm, 0.0);
    }
    v
}

/// One-call convenience: the periodic steady state of `kane`'s mechanism at order `order` (see
/// [`Hbm::new`] for the arguments), with its Floquet stability when
/// `options.stability_samples > 0`.
pub fn solve_periodic(
    kane: &Kane,
    spin_joint: usize,
    omega: f64,
    harmonics: &[Harmonic],
    order: f64,
    guess: Option<&HbmSolution>,
    options: HbmOptions,
) -> Result<HbmSolution, HbmError> {
    let mut hbm = Hbm::new(kane, spin_joint, omega, harmonics, options)?;
    let mut sol = hbm.solve(order, guess)?;
    if options.stability_samples > 0 {
        sol.stability = Some(hbm.stability(&sol)?);
    }
    Ok(sol)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The tree route's multipliers (Butcher's sixth order, 64 steps at the default N_s = 256)
    /// against an independent route at a tight step: the dense monodromy of
    /// `[K | L] = C⁻¹[A | B]` by RK4 with Richardson's extrapolation at N_s = 2048 (768 steps).
    /// Also printed: the dense route at the default N_s, which is what the tree route computed
    /// before (RK4 and Richardson at N_s = 256, equal to it to 3e-12). `pendulums` pendulums, the
    /// j-th mass times `1 + mistuning(j)`, at `torque` N·m and the orders given. Returns the
    /// largest distance of the tree route's multipliers from the tight ones, and of the old
    /// route's.
    fn tree_against_tight(pendulums: usize, mistuning: impl Fn(f64) -> f64, torque: f64, orders: &[f64]) -> (f64, f64) {
        let n = pendulums;
        let mut mech = crate::cpva::CpvaParams::canonical().with_pendulums(n).mechanism(None).unwrap();
        for j in 0..n {
            let b = mech.body_index(&format!("pendulum_{}", j + 1)).unwrap();
            mech.bodies[b].inertia.mass *= 1.0 + mistuning(j as f64 / (n - 1) as f64);
        }
        let kane = crate::kane::Kane::new(&mech).unwrap();
        let h = [crate::model::excitation::Harmonic { multiple: 1.0, amplitude: torque, phase: 0.0 }];
        let omega = crate::model::excitation::rpm_to_rad_s(1000.0);
        let mut hbm = Hbm::new(&kane, 0, omega, &h, Default::default()).unwrap();
        let tight = HbmOptions { stability_samples: 2048, ..Default::default() };
        let mut dense = Hbm::new(&kane, 0, omega, &h, tight).unwrap();
        let all: Vec<usize> = (0..=n).collect();
        let diff =
            |a: &[Complex<f64>], b: &[Complex<f64>]| a.iter().zip(b).map(|(x, y)| (x - y).norm()).fold(0.0, f64::max);
        let (mut worst, mut worst_old) = (0.0f64, 0.0f64);
        for &order in orders {
            let sol = hbm.solve(order, None).unwrap();
            let period = 2.0 * PI / sol.base_frequency;
            let tree = hbm.stability(&sol).unwrap().multipliers;
            let scheme = hbm.tree_scheme(period, sol.omega);
            println!("n = {order}: |λ|max T = {:.2}, {scheme:?}", hbm.tree_rate.unwrap().0 * period);
            assert_eq!(scheme, TreeScheme::Butcher6 { steps: 64 }, "{pendulums} pendulums at n = {order}");
            let old = hbm.block_multipliers(&all, Some(0), order, period, None).unwrap();
            let _ = dense.stability(&sol).unwrap();
            let reference = dense.block_multipliers(&all, Some(0), order, period, None).unwrap();
            let (e, e_old) = (diff(&tree, &reference), diff(&old, &reference));
            println!(
                "{n} pendulums, {torque} N·m, n = {order}: |μ| max {:.6}; tree (Butcher 6) vs tight {e:.2e}, \
                 RK4 + Richardson at 256 vs tight {e_old:.2e}, tree vs it {:.2e}",
                reference[0].norm(),
                diff(&tree, &old)
            );
            assert_eq!(tree.len(), 2 * n + 1);
            (worst, worst_old) = (worst.max(e), worst_old.max(e_old));
        }
        (worst, worst_old)
    }

    /// 8 pendulums mistuned by up to 1 %, 500 N·m, on both sides of the resonance: the tree
    /// route's multipliers within 1e-8 of the tight dense route's.
    #[test]
    fn tree_monodromy_of_8_pendulums_at_500_nm_against_a_tight_dense_one() {
        let (e, _) = tree_against_tight(8, |x| 0.01 * x, 500.0, &[2.95, 3.05]);
        assert!(e <= 1e-8, "{e:e}");
    }

    /// 16 pendulums mistuned by ±1 % (the `hbm_scale` bench's rotor), 40 N·m, on both sheets
    /// around the folds and between: the tree route's multipliers within 1e-8 of the tight
    /// dense route's, and no further from them than the route it replaced.
    #[test]
    fn tree_monodromy_of_16_mistuned_pendulums_against_a_tight_dense_one() {
        let (e, e_old) = tree_against_tight(16, |x| 0.01 * (2.0 * x - 1.0), 40.0, &[2.92, 3.0, 3.1, 3.2, 3.3]);
        assert!(e <= 1e-8 && e <= e_old, "{e:e} (before: {e_old:e})");
    }

    /// A stiff mechanism on the tree route: the OpenTorsion marine plant with the README's
    /// pendulum (`examples/opentorsion_marine_cpva.ron`, 7 coordinates), 35.6 rpm, the
    /// propeller's fifth order at 10 % of full-power torque (`python/tests/test_opentorsion.py`).
    /// Its turbine shafts vibrate far faster than the excitation (|λ|max T ≈ 90–115), so N_s/4 steps
    /// of Butcher's method leave its stability region (taken regardless, every point of this
    /// branch had multipliers of modulus 2.6–8.8). The scheme chosen must be RK4 with
    /// Richardson, and then give what the dense route gives with the same method at the same
    /// N_s (an independent code path: `[K | L] = C⁻¹[A | B]` in full) to 1e-9, every multiplier
    /// inside the unit circle as the tight dense route (N_s = 4096, steps 16× finer) finds them;
    /// Butcher's method forced to N_s/4 steps must be the unstable result this guards against.
    /// (At N_s = 256 both routes get the fast shaft modes' multipliers wrong — the moduli are
    /// printed beside the tight route's — but inside the unit circle, as the tight route's.)
    #[test]
    fn a_stiff_plant_on_the_tree_route_keeps_rk4_and_its_stable_multipliers() {
        let mech =
            crate::model::mechanism::Mechanism::from_file(std::path::Path::new("examples/opentorsion_marine_cpva.ron"))
                .unwrap();
        let kane = crate::kane::Kane::new(&mech).unwrap();
        let spin = mech.joint_index("node_1").unwrap();
        let rpm = 35.6;
        let amplitude = 0.1 * 22.24e6 * 0.11298 * (rpm / 85.0f64).powi(2);
        let h = [crate::model::excitation::Harmonic { multiple: 1.0, amplitude, phase: 0.0 }];
        let omega = crate::model::excitation::rpm_to_rad_s(rpm);
        let opts = HbmOptions { harmonics: 5, ..Default::default() };
        let mut hbm = Hbm::new(&kane, spin, omega, &h, opts).unwrap();
        assert_eq!(hbm.n, 7);
        let tight = HbmOptions { harmonics: 5, stability_samples: 4096, ..Default::default() };
        let mut fine = Hbm::new(&kane, spin, omega, &h, tight).unwrap();
        let all: Vec<usize> = (0..hbm.n).collect();
        let drop = Some(hbm.spin);
        let diff =
            |a: &[Complex<f64>], b: &[Complex<f64>]| a.iter().zip(b).map(|(x, y)| (x - y).norm()).fold(0.0, f64::max);
        for order in [5.5, 5.2, 4.8, 4.5] {
            let sol = hbm.solve(order, None).unwrap();
            let period = 2.0 * PI / sol.base_frequency;
            let (rate, _) = hbm.tree_rate.unwrap();
            let scheme = hbm.tree_scheme(period, sol.omega);
            let got = hbm.stability(&sol).unwrap().multipliers;
            let dense = hbm.block_multipliers(&all, drop, order, period, None).unwrap();
            let forced = hbm.block_multipliers(&all, drop, order, period, Some(TreeScheme::Butcher6 { steps: 64 }));
            let _ = fine.stability(&sol).unwrap();
            let reference = fine.block_multipliers(&all, drop, order, period, None).unwrap();
            let e = diff(&got, &dense);
            let forced_max = forced.as_ref().map_or(f64::NAN, |m| m[0].norm());
            let moduli =
                |m: &[Complex<f64>]| m.iter().map(|x| format!("{:.4}", x.norm())).collect::<Vec<_>>().join(" ");
            println!(
                "n = {order}: |λ|max T = {:.1}, {scheme:?}; tree vs dense at 256 {e:.2e}, vs tight {:.2e}; \
                 Butcher at 64 steps: |μ| max {forced_max:.3}\n  |μ| tree {}\n  |μ| tight {}",
                rate * period,
                diff(&got, &reference),
                moduli(&got),
                moduli(&reference)
            );
            assert_eq!(scheme, TreeScheme::Rk4Richardson);
            assert!(e <= 1e-9, "{e:e}");
            assert!(got[0].norm() < 1.0 && reference[0].norm() < 1.0);
            assert!(forced_max > 1.5, "{forced_max}");
        }
    }

    /// The pairs' eigenvectors by inverse iteration on the Schur form's Hessenberg T are
    /// eigenvectors of the matrix itself (residual ‖(Φ − μ)v‖ below 1e-12) and the dense route's
    /// vectors up to a phase (|vᴴw| = 1 to 1e-12), with the same senses, on a 7 × 7 matrix with
    /// two pairs near +1 and one near −1 hidden by an arbitrary similarity.
    #[test]
    fn pair_vectors_from_the_schur_form_are_the_dense_ones() {
        let d = 7;
        // Block diagonal: rotations by 0.3, 0.1 and π − 0.2 (radius 0.99), and one real 0.5.
        let mut b = DMatrix::zeros(d, d);
        for (k, (angle, r)) in [(0.3f64, 0.99), (0.1, 0.98), (PI - 0.2, 0.99)].into_iter().enumerate() {
            let (c, s) = (r * angle.cos(), r * angle.sin());
            b[(2 * k, 2 * k)] = c;
            b[(2 * k, 2 * k + 1)] = -s;
            b[(2 * k + 1, 2 * k)] = s;
            b[(2 * k + 1, 2 * k + 1)] = c;
        }
        b[(6, 6)] = 0.5;
        let x = DMatrix::from_fn(d, d, |i, j| if i == j { 2.0 } else { ((i * 7 + j * 3) % 5) as f64 * 0.1 - 0.2 });
        let m = &x * b * x.clone().try_inverse().unwrap();
        let flat: Vec<f64> = (0..d).flat_map(|i| (0..d).map(move |j| (i, j))).map(|(i, j)| m[(i, j)]).collect();
        // Read as four coordinates with the fourth angle removed (7 = 2·4 − 1 states), as the
        // cyclic spin angle is.
        let (multipliers, dense) = finish(flat, d, None, None, 3.0).unwrap();
        // Below `SCHUR_PAIRS_FROM` `finish` leaves the Schur form out; here it is put back.
        assert!(dense.schur.is_none());
        let reduced = Reduced { matrix: dense.matrix.clone(), schur: eigen(dense.matrix.clone()).unwrap().1 };
        assert!(reduced.schur.is_some());
        let (fast, slow) =
            (pair_senses(&reduced, &multipliers, 4, Some(3)), pair_senses(&dense, &multipliers, 4, Some(3)));
        assert_eq!(fast.len(), 3);
        assert_eq!(slow.len(), 3);
        for (f, s) in fast.iter().zip(&slow) {
            let overlap: Complex<f64> = f.v.iter().zip(s.v.iter()).map(|(a, b)| a.conj() * b).sum();
            let mu = multipliers.iter().copied().filter(|m| m.im > 0.0).min_by(|a, b| {
                let r = |m: &Complex<f64>| (reduced.matrix.map(|x| Complex::new(x, 0.0)) * &f.v - &f.v * *m).norm();
                r(a).total_cmp(&r(b))
            });
            let residual = (reduced.matrix.map(|x| Complex::new(x, 0.0)) * &f.v - &f.v * mu.unwrap()).norm();
            println!(
                "side {}: sense {:.15} vs {:.15}, |vᴴw| − 1 = {:.1e}, residual {residual:.1e}",
                f.side,
                f.sense,
                s.sense,
                overlap.norm() - 1.0
            );
            assert_eq!(f.side, s.side);
            assert!((f.sense - s.sense).abs() <= 1e-12);
            assert!((overlap.norm() - 1.0).abs() <= 1e-12 && residual <= 1e-12);
        }
    }
}
