//! Floquet stability of a harmonic-balance solution from its monodromy matrix.
//!
//! The variational equations of `R(q, q̇, q̈, t) = 0` about the periodic orbit are
//! `C δq̈ + B δq̇ + A δq = 0` with the per-sample derivatives A, B, C of the harmonic balance
//! (`C = M W` is invertible). In the state `z = (δq, δq̇)` they read `ż = 𝒜(t) z`,
//! `𝒜 = [[0, I], [−C⁻¹A, −C⁻¹B]]`. A, B, C are those of the last Jacobian of the harmonic balance
//! at the solution (N_t samples; no new engine calls when the continuation just assembled it);
//! `K = C⁻¹A` and `L = C⁻¹B` are formed at those samples and carried to N_s equally spaced
//! instants of the period T = 2π/ω₀ by trigonometric interpolation, one FFT pair per entry
//! (they are smooth periodic functions, band-limited to far below N_t/2 on the branches
//! checked), and the monodromy matrix Φ(T) is integrated by the classical fourth-order
//! Runge–Kutta method with steps 2T/N_s and 4T/N_s, whose stages fall exactly on the samples
//! (t, t + h/2, t + h), and Richardson-extrapolated, `(16 Φ_h − Φ_2h)/15`, which leaves a
//! sixth-order error. Measured on the canonical CPVA's 40 N·m branch: N_s = 256 agrees with
//! N_s = 2048 to 9e-8 (plain RK4 at 256 was off by 1.7e-5, too close to the margin below),
//! and the multipliers agree with a monodromy matrix differenced from time integrations to
//! 2e-6 (tests/it/hbm.rs).
//!
//! Beyond six coordinates the whole mechanism is integrated by its tree instead (`tree_monodromy`):
//! in the states `(δq, δu)`, `δu = W δq̇`, with A, B W⁻¹ and W⁻¹ kept sparse and the mass matrix
//! `M = C W⁻¹` applied through its LDLᵀ factors, which a leaves-first order leaves as sparse as
//! the tree, at a cost per stage that grows with the tree's non-zeros instead of with n³. There
//! the period is integrated once by Butcher's seven-stage sixth-order Runge–Kutta method
//! (`rk6_period`), from N_s/4 steps up, its coefficients interpolated to a grid of six instants
//! per step (the stages sit at 0, 1/3, 1/2, 2/3 and 1 of a step), instead of the fine and coarse
//! RK4 runs: 448 derivative evaluations instead of 768 at the default N_s = 256, and more
//! accurate on the rotors measured (16 pendulums mistuned by ±1 % at 40 N·m: the multipliers
//! within 2.9e-9–6.9e-9 of a dense monodromy at N_s = 2048, where RK4 with Richardson at
//! N_s = 256 was within 1.1e-8–2.3e-8; unit tests). An explicit method is accurate and stable
//! only while the step times the fastest rate stays small, and Butcher's method leaves the unit
//! disc on the imaginary axis sooner than RK4 with Richardson does: the step count comes from
//! the fastest eigenvalue of the mechanism linearised about its steady spin, computed once per
//! problem (`butcher6_steps`: no less accurate on that mode than RK4 with Richardson, by their
//! stability functions), and where that would take more derivatives than RK4 with Richardson
//! (a stiff shaft, as in the OpenTorsion marine plant) the tree route runs RK4 with Richardson.
//! Either integration is compiled a second time for AVX2 and taken where the processor has it:
//! the same element-wise operations on four doubles instead of two (no fused multiply-adds), so
//! the same bits (a unit test).
//!
//! The spin angle is cyclic: its column of A is zero, so `δq_s` feeds nothing and the column of
//! Φ for it is the unit vector — the trivial multiplier +1 (a shift of the spin angle is again a
//! solution). Deleting that row and column leaves the 2n_dof − 1 physical multipliers. One of
//! them belongs to the mean spin speed and sits just inside the unit circle,
//! `≈ exp(−c_r T / J_locked)` (for the canonical CPVA 1 − 3·10⁻⁵), so the integration must be
//! accurate well below that margin; the tests compare the multipliers with a monodromy matrix
//! obtained by differencing full time integrations.

use super::{Hbm, HbmError, HbmSolution};
use nalgebra::{Complex, DMatrix, DVector};
use std::f64::consts::PI;

/// Floquet multipliers of a periodic solution and the verdict.
#[derive(Debug, Clone, PartialEq)]
pub struct Stability {
    /// The 2n_dof − 1 physical Floquet multipliers (the trivial +1 of the cyclic spin angle is
    /// removed), by decreasing modulus; a block's multipliers appear `multiplicity` times.
    pub multipliers: Vec<Complex<f64>>,
    /// The groups the multipliers were computed in: one block holding all of them on the general
    /// route; on a cyclic route the unison block and the non-unison (wavenumber) blocks, each
    /// standing for `multiplicity` identical copies. Bifurcation test functions are evaluated per
    /// block, so a multiplier repeated by symmetry crosses once, not `multiplicity` times.
    pub blocks: Vec<FloquetBlock>,
    /// Largest modulus of the multipliers.
    pub max_modulus: f64,
    /// True when every multiplier lies inside the unit circle (asymptotically stable).
    pub stable: bool,
}

/// Floquet multipliers computed together from one block of the variational equations.
#[derive(Debug, Clone, PartialEq)]
pub struct FloquetBlock {
    /// What the block describes (`all`, `unison`, `wavenumbers 1..N-1`, …).
    pub label: String,
    /// How many identical copies of this block the full problem holds (1 on the general route).
    pub multiplicity: usize,
    /// The block's multipliers, by decreasing modulus.
    pub multipliers: Vec<Complex<f64>>,
}

impl Stability {
    /// A verdict from blocks: the multipliers of every block, repeated by its multiplicity.
    pub fn from_blocks(blocks: Vec<FloquetBlock>) -> Self {
        let mut multipliers: Vec<Complex<f64>> =
            blocks.iter().flat_map(|b| (0..b.multiplicity).flat_map(|_| b.multipliers.iter().copied())).collect();
        multipliers.sort_by(|a, b| b.norm().total_cmp(&a.norm()));
        let max_modulus = multipliers.first().map_or(0.0, |m| m.norm());
        Self { multipliers, max_modulus, stable: max_modulus < 1.0, blocks }
    }

    /// The multiplier of largest modulus (the critical one when unstable).
    pub fn critical(&self) -> Option<Complex<f64>> {
        self.multipliers.first().copied()
    }

    /// Number of multipliers outside the unit circle (0: stable).
    pub fn outside(&self) -> usize {
        self.multipliers.iter().filter(|m| m.norm() > 1.0).count()
    }
}

impl Hbm {
    /// Floquet multipliers of a solution of this problem (see the module docs of
    /// [`crate::hbm`]): monodromy by RK4 with Richardson's extrapolation over the variational
    /// equations with [`super::HbmOptions::stability_samples`] samples per period (beyond six
    /// coordinates by Butcher's sixth-order method from a quarter as many steps where the
    /// mechanism's fastest rate allows; module docs). One block (`all`) on the
    /// general route; on the reduced problem of the cyclic route ([`super::RoutedHbm`]) the
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
        let at = super::At { order, omega: sol.omega, scale: sol.torque_scale };
        let same = |(xs, o): &(Vec<f64>, super::At)| {
            *o == at && xs.iter().zip(&x).all(|(a, b)| (a - b).abs() <= 1e-14 * (1.0 + b.abs()))
        };
        if !self.samples_at.as_ref().is_some_and(same) {
            self.assemble(&x, &at, Some(super::Parameter::Order));
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
        // non-zero wavenumber (`super::cyclic`).
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

    /// Φ(T) of the whole mechanism, row-major, in the states `(δq, δu)` with `δu = W δq̇` (W is
    /// constant, so Φ is similar to the one in `(δq, δq̇)` and has the same multipliers; a
    /// Runge–Kutta method commutes with the constant change of variables), integrated by
    /// `scheme`:
    ///
    /// `δq̇ = W⁻¹ δu`, `M δu̇ = −A δq − B W⁻¹ δu`, with `M = C W⁻¹` the mass matrix.
    ///
    /// NOTE: the dense route forms `[K | L] = C⁻¹[A | B]`, which is full even on a tree (M⁻¹
    /// couples every absorber through the rotor), so each RK4 stage costs 2n²·2n. Here A, B W⁻¹
    /// and W⁻¹ keep the tree's zeros (an absorber's rows touch itself and its ancestors only) and
    /// M is applied through its LDLᵀ factors in a fill-free order (greedy minimum degree on its
    /// pattern: the leaves first, which for a tree adds no entry), so a stage costs
    /// O(nnz·2n): on 16 pendulums (n = 17) ≈ 200 row operations of length 34 per stage against
    /// 17 · 34 · 34 multiply-adds (`BENCHMARKS.md`). The interpolated series are the non-zeros
    /// of A, B W⁻¹ and M (≈ 6n instead of 2n²). None when W is singular or M has a
    /// non-positive pivot (the caller then takes the dense route).
    fn tree_monodromy(&mut self, period: f64, scheme: TreeScheme) -> Option<Vec<f64>> {
        // Butcher's stages sit at multiples of a sixth of a step (`BUTCHER6_C`); RK4's at the
        // N_s samples.
        let (n, nt) = (self.n, self.aft.nt);
        let ns = match scheme {
            TreeScheme::Butcher6 { steps } => {
                if self.tree_upsampler.as_ref().is_none_or(|u| u.samples() != 6 * steps) {
                    self.tree_upsampler = Some(super::aft::Upsampler::new(6 * steps));
                }
                6 * steps
            }
            TreeScheme::Rk4Richardson => self.opts.stability_samples,
        };
        let nn = n * n;
        let winv = DMatrix::from_row_slice(n, n, &self.ev.w).try_inverse()?;
        let winv_nz: Vec<(usize, usize, f64)> = (0..n)
            .flat_map(|i| (0..n).map(move |k| (i, k)))
            .filter_map(|(i, k)| {
                let v = winv[(i, k)];
                (v != 0.0).then_some((i, k, v))
            })
            .collect();
        // W⁻¹'s non-zeros row by row (in the order of `winv_nz`).
        let mut winv_rows: Vec<Vec<(usize, f64)>> = vec![Vec::new(); n];
        for &(l, k, v) in &winv_nz {
            winv_rows[l].push((k, v));
        }
        // M = C W⁻¹ and B W⁻¹ at the N_t samples (row-major n × n each), and the union of their
        // and A's non-zero patterns over the samples.
        // The work arrays are kept between calls (`Hbm::tree_buffers`): fresh ones of this size
        // are mapped anew by the allocator at every call, and their pages faulted in and zeroed.
        let [mut m, mut bw, mut raw, mut inst] = std::mem::take(&mut self.tree_buffers);
        let sized = |v: &mut Vec<f64>, len: usize| {
            v.clear();
            v.resize(len, 0.0);
        };
        sized(&mut m, nt * nn);
        sized(&mut bw, nt * nn);
        let (mut a_pat, mut b_pat, mut m_pat) = (vec![false; nn], vec![false; nn], vec![false; nn]);
        for j in 0..nt {
            let abc = &self.samples[j * 3 * nn..(j + 1) * 3 * nn];
            let (mj, bj) = (&mut m[j * nn..(j + 1) * nn], &mut bw[j * nn..(j + 1) * nn]);
            for i in 0..n {
                for l in 0..n {
                    let (b, c) = (abc[nn + i * n + l], abc[2 * nn + i * n + l]);
                    if b == 0.0 && c == 0.0 {
                        continue;
                    }
                    for &(k, v) in &winv_rows[l] {
                        bj[i * n + k] += b * v;
                        mj[i * n + k] += c * v;
                    }
                }
            }
            for e in 0..nn {
                a_pat[e] |= abc[e] != 0.0;
                b_pat[e] |= bj[e] != 0.0;
                m_pat[e] |= mj[e] != 0.0;
            }
        }
        let sym = |i: usize, k: usize| m_pat[i * n + k] || m_pat[k * n + i];
        // Symbolic LDLᵀ: greedy minimum degree with the fill it makes, `perm[p]` the coordinate
        // eliminated p-th, `below[p]` the rows (in elimination positions) of L's column p.
        let mut adj: Vec<Vec<bool>> = (0..n).map(|i| (0..n).map(|k| i != k && sym(i, k)).collect()).collect();
        let mut alive = vec![true; n];
        let mut perm = Vec::with_capacity(n);
        for _ in 0..n {
            let k = (0..n).filter(|&b| alive[b]).min_by_key(|&b| (0..n).filter(|&o| alive[o] && adj[b][o]).count())?;
            let nbrs: Vec<usize> = (0..n).filter(|&o| alive[o] && adj[k][o]).collect();
            for &a in &nbrs {
                for &b in &nbrs {
                    if a != b {
                        adj[a][b] = true;
                    }
                }
            }
            alive[k] = false;
            perm.push(k);
        }
        let mut pinv = vec![0; n];
        for (p, &k) in perm.iter().enumerate() {
            pinv[k] = p;
        }
        // The filled pattern, in elimination positions: L's column p holds the neighbours
        // eliminated after p (adj holds the fill now).
        let below: Vec<Vec<usize>> = (0..n)
            .map(|p| {
                let mut rows: Vec<usize> =
                    (0..n).filter(|&o| adj[perm[p]][o] && pinv[o] > p).map(|o| pinv[o]).collect();
                rows.sort_unstable();
                rows
            })
            .collect();
        let l_count: usize = below.iter().map(Vec::len).sum();
        // The series to interpolate: A's and B W⁻¹'s non-zeros, and M's lower triangle (in
        // elimination positions) on the filled pattern.
        let a_nz: Vec<(usize, usize)> = (0..nn).filter(|&e| a_pat[e]).map(|e| (e / n, e % n)).collect();
        let b_nz: Vec<(usize, usize)> = (0..nn).filter(|&e| b_pat[e]).map(|e| (e / n, e % n)).collect();
        let m_nz: Vec<(usize, usize)> = (0..n)
            .flat_map(|p| std::iter::once((p, p)).chain(below[p].iter().map(move |&i| (i, p))))
            .filter(|&(i, p)| i == p || sym(perm[i], perm[p]))
            .collect();
        let (na, nbz, nm) = (a_nz.len(), b_nz.len(), m_nz.len());
        let width = na + nbz + nm;
        let mut series = vec![0.0; nt];
        let mut spec = vec![Default::default(); self.aft.half_len()];
        let mut up = vec![0.0; ns];
        // Every entry of `raw` is written below; `inst` only where an instant is read.
        raw.resize(ns * width, 0.0);
        for e in 0..width {
            for (j, v) in series.iter_mut().enumerate() {
                *v = if e < na {
                    let (i, k) = a_nz[e];
                    self.samples[j * 3 * nn + i * n + k]
                } else if e < na + nbz {
                    let (i, k) = b_nz[e - na];
                    bw[j * nn + i * n + k]
                } else {
                    let (i, p) = m_nz[e - na - nbz];
                    m[j * nn + perm[i] * n + perm[p]]
                };
            }
            self.aft.spectrum(&series, &mut spec);
            match scheme {
                TreeScheme::Butcher6 { .. } => self.tree_upsampler.as_mut()?.run(&spec, nt, &mut up),
                TreeScheme::Rk4Richardson => self.upsampler.run(&spec, nt, &mut up),
            }
            for (j, &v) in up.iter().enumerate() {
                raw[j * width + e] = v;
            }
        }
        // Per instant: [A values | B W⁻¹ values | L (column by column, as `below`) | D⁻¹]; D's
        // reciprocals, because the division of a stage's rows by D was a sixth of the
        // integration's samples (`vdivpd`), its product a few percent. Butcher's stages never
        // read two grid instants of the six per step (`BUTCHER6_C`: 1 and 5): those are not
        // factorised.
        let stride = na + nbz + l_count + n;
        inst.resize(ns * stride, 0.0);
        let mut s = vec![0.0; nn];
        let read = |j: usize| match scheme {
            TreeScheme::Butcher6 { .. } => BUTCHER6_C.contains(&(j % 6)),
            TreeScheme::Rk4Richardson => true,
        };
        for j in (0..ns).filter(|&j| read(j)) {
            let r = &raw[j * width..(j + 1) * width];
            let out = &mut inst[j * stride..(j + 1) * stride];
            out[..na + nbz].copy_from_slice(&r[..na + nbz]);
            s.fill(0.0);
            for (e, &(i, p)) in m_nz.iter().enumerate() {
                s[i * n + p] = r[na + nbz + e];
            }
            let mut l = na + nbz;
            for p in 0..n {
                let d = s[p * n + p];
                if !(d > 0.0 && d.is_finite()) {
                    return None;
                }
                for (x, &i) in below[p].iter().enumerate() {
                    for &i2 in &below[p][..=x] {
                        s[i * n + i2] -= s[i * n + p] * s[i2 * n + p] / d;
                    }
                }
                for &i in &below[p] {
                    out[l] = s[i * n + p] / d;
                    l += 1;
                }
                out[na + nbz + l_count + p] = 1.0 / d;
            }
        }
        let system = TreeSystem { n, winv_nz, a_nz, b_nz, pinv, perm, below, na, nbz, l_count };
        let instants = Instants { values: &inst, stride, ns };
        #[cfg(target_arch = "x86_64")]
        let phi = if std::arch::is_x86_feature_detected!("avx2") {
            // SAFETY: the processor has AVX2 (detected just above).
            unsafe { system.monodromy_avx2(&instants, period, scheme) }
        } else {
            system.monodromy(&instants, period, scheme)
        };
        #[cfg(not(target_arch = "x86_64"))]
        let phi = system.monodromy(&instants, period, scheme);
        self.tree_buffers = [m, bw, raw, inst];
        Some(phi)
    }
}

/// How the tree route integrates the period (`Hbm::tree_monodromy`).
#[derive(Clone, Copy, Debug, PartialEq)]
enum TreeScheme {
    /// Butcher's sixth-order method in `steps` steps of T/steps.
    Butcher6 { steps: usize },
    /// RK4 at steps 2T/N_s and 4T/N_s with Richardson's extrapolation, on the N_s samples.
    Rk4Richardson,
}

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
fn butcher6_steps(rate: f64, period: f64, ns: usize) -> Option<usize> {
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

/// A complex pair of Floquet multipliers near +1 or −1 and the sense in which its eigenvector
/// turns. Along a branch the member with Im μ > 0 of a lightly damped pair belongs to a motion
/// that turns one way in the phase plane of each coordinate (δq̇ ≈ iω δq for a mode of frequency
/// ω whose multiplier is e^{iωT}); when the pair passes through ±1 (meets on the real axis,
/// splits, meets again and leaves: a tongue of period doubling or of loss of unison) the
/// rotation number ωT/2π passes through ½ or an integer and the member with Im μ > 0 becomes the
/// conjugate of the old one, so the sense flips. A pair that comes near ±1 and leaves without
/// meeting on the real axis keeps it. This sign is the continuation's test for a tongue
/// stepped over whole (its module docs).
#[derive(Debug, Clone)]
pub(super) struct PairSense {
    /// +1 or −1: the real multiplier the pair is near.
    pub(super) side: f64,
    /// `Σ_k Im(conj(v_qk) v_uk) / (|v_q| |v_u|)` over the coordinates k with both an angle and a
    /// rate in the state: the sign says the sense of turning (phase-invariant, in [−1, 1]).
    pub(super) sense: f64,
    /// The unit eigenvector of the member with Im μ > 0, to recognise the same pair at the next
    /// point.
    pub(super) v: DVector<Complex<f64>>,
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

/// True when every entry below the first subdiagonal is zero.
fn is_hessenberg(t: &DMatrix<f64>) -> bool {
    (0..t.ncols()).all(|j| (j + 2..t.nrows()).all(|i| t[(i, j)] == 0.0))
}

/// LU with partial pivoting of `H − s I`, H real upper Hessenberg: each column has one entry
/// below the diagonal, so a step swaps at most two adjacent rows and updates one.
struct HessenbergLu {
    /// U in the upper triangle; the multiplier of step k at (k + 1, k).
    lu: DMatrix<Complex<f64>>,
    /// Whether step k swapped rows k and k + 1.
    swapped: Vec<bool>,
}

impl HessenbergLu {
    /// None when a pivot is zero or not finite.
    fn new(h: &DMatrix<f64>, s: Complex<f64>) -> Option<Self> {
        let d = h.nrows();
        if d == 0 {
            return None;
        }
        let mut lu = h.map(|x| Complex::new(x, 0.0));
        for k in 0..d {
            lu[(k, k)] -= s;
        }
        let mut swapped = vec![false; d];
        for k in 0..d.saturating_sub(1) {
            if lu[(k + 1, k)].norm() > lu[(k, k)].norm() {
                // From column k on: left of it row k holds the previous step's multiplier and
                // row k + 1 zeros.
                for j in k..d {
                    lu.swap((k, j), (k + 1, j));
                }
                swapped[k] = true;
            }
            let p = lu[(k, k)];
            if !(p.norm() > 0.0 && p.norm().is_finite()) {
                return None;
            }
            let l = lu[(k + 1, k)] / p;
            lu[(k + 1, k)] = l;
            for j in k + 1..d {
                let u = lu[(k, j)];
                lu[(k + 1, j)] -= l * u;
            }
        }
        let last = lu[(d - 1, d - 1)].norm();
        (last > 0.0 && last.is_finite()).then_some(Self { lu, swapped })
    }

    /// `(H − s I)⁻¹ b`; None when not finite.
    fn solve(&self, b: &DVector<Complex<f64>>) -> Option<DVector<Complex<f64>>> {
        let d = b.len();
        let mut x = b.clone();
        for k in 0..d.saturating_sub(1) {
            if self.swapped[k] {
                x.swap_rows(k, k + 1);
            }
            let v = x[k];
            x[k + 1] -= self.lu[(k + 1, k)] * v;
        }
        for i in (0..d).rev() {
            let mut v = x[i];
            for j in i + 1..d {
                v -= self.lu[(i, j)] * x[j];
            }
            x[i] = v / self.lu[(i, i)];
        }
        x.iter().all(|c| c.re.is_finite() && c.im.is_finite()).then_some(x)
    }
}

/// Eigenvalues of a real square matrix by methods bounded in work; None when neither converges.
/// First nalgebra's real Schur form with an iteration cap (30 sweeps per row): on the sizes of
/// the paper's absorbers it costs a third of faer's instructions (`BENCHMARKS.md`). Its Francis
/// QR has no exceptional shifts, though, and never returned on the repeated multipliers of 4
/// identical pendulums at 500 N·m (issue 26); where the cap stops it, faer's real Schur form
/// (Hessenberg reduction, Francis double-shift QR with exceptional shifts and aggressive early
/// deflation, as LAPACK's dhseqr, itself capped) takes over.
///
/// Also returns the real Schur form `(Q, T)` when nalgebra's gave the eigenvalues.
#[allow(clippy::type_complexity)]
fn eigen(m: DMatrix<f64>) -> Option<(Vec<Complex<f64>>, Option<(DMatrix<f64>, DMatrix<f64>)>)> {
    let d = m.nrows();
    if d == 0 {
        return Some((Vec::new(), None));
    }
    let finite = |v: &[Complex<f64>]| v.iter().all(|c| c.re.is_finite() && c.im.is_finite());
    if let Some(s) = nalgebra::Schur::try_new(m.clone(), f64::EPSILON, 30 * d) {
        let out: Vec<Complex<f64>> = s.complex_eigenvalues().iter().copied().collect();
        if finite(&out) {
            return Some((out, Some(s.unpack())));
        }
    }
    let f = faer::Mat::<f64>::from_fn(d, d, |i, j| m[(i, j)]);
    let ev = f.eigenvalues().ok()?;
    let out: Vec<Complex<f64>> = ev.iter().map(|c| Complex::new(c.re, c.im)).collect();
    finite(&out).then_some((out, None))
}

/// Φ(T), row-major 2n × 2n, of `ż = 𝒜 z`, `𝒜 = [[0, I], [−K, −L]]`, by RK4 with steps
/// 2T/N_s and 4T/N_s, Richardson-extrapolated (which removes RK4's h⁴ error term); `sys` holds
/// `[K | L]` (n rows of 2n, row-major) at the N_s instants, and the stages use every (or every
/// other) instant. Small systems go through fixed-size arrays, padded with
/// decoupled states up to the next supported size: the generic slice loop spends most of its
/// time on loop and bounds overhead at 4 × 4 (instruction counts of the single-pendulum CPVA's
/// stability analysis before and after: `BENCHMARKS.md`).
fn monodromy(sys: &[f64], n: usize, ns: usize, period: f64) -> Vec<f64> {
    let (fine, coarse) = match 2 * n {
        d if d <= 4 => monodromy_fixed::<4>(sys, n, ns, period),
        d if d <= 6 => monodromy_fixed::<6>(sys, n, ns, period),
        d if d <= 8 => monodromy_fixed::<8>(sys, n, ns, period),
        d if d <= 12 => monodromy_fixed::<12>(sys, n, ns, period),
        _ => (monodromy_slices(sys, n, ns, 1, period), monodromy_slices(sys, n, ns, 2, period)),
    };
    richardson(&fine, &coarse)
}

/// The variational equations of the whole mechanism in the states `(δq, δu)` as the tree keeps
/// them sparse (`Hbm::tree_monodromy`): the non-zeros of W⁻¹, A and B W⁻¹, and the LDLᵀ
/// factors of M in a fill-free elimination order.
struct TreeSystem {
    n: usize,
    /// W⁻¹'s non-zeros (row, column, value).
    winv_nz: Vec<(usize, usize, f64)>,
    /// A's and B W⁻¹'s non-zero positions; their values at an instant lead the instant's slice.
    a_nz: Vec<(usize, usize)>,
    b_nz: Vec<(usize, usize)>,
    /// Elimination position of each coordinate, and the coordinate eliminated at each position.
    pinv: Vec<usize>,
    perm: Vec<usize>,
    /// Rows (elimination positions) of L's column p.
    below: Vec<Vec<usize>>,
    na: usize,
    nbz: usize,
    l_count: usize,
}

/// `x += f y`.
#[inline(always)]
fn row(x: &mut [f64], y: &[f64], f: f64) {
    for (a, &b) in x.iter_mut().zip(y) {
        *a += f * b;
    }
}

impl TreeSystem {
    /// `out = 𝒜Φ` with the instant's values `c` (`[A | B W⁻¹ | L | D]`), Φ row-major 2n × 2n;
    /// `g` is scratch of n × 2n.
    #[inline(always)]
    fn deriv(&self, c: &[f64], phi: &[f64], out: &mut [f64], g: &mut [f64]) {
        let (n, d2) = (self.n, 2 * self.n);
        let (na, nbz) = (self.na, self.nbz);
        let (top, bottom) = out.split_at_mut(n * d2);
        let (pq, pu) = phi.split_at(n * d2);
        top.fill(0.0);
        for &(i, k, v) in &self.winv_nz {
            row(&mut top[i * d2..(i + 1) * d2], &pu[k * d2..(k + 1) * d2], v);
        }
        g.fill(0.0);
        for (e, &(i, k)) in self.a_nz.iter().enumerate() {
            let p = self.pinv[i];
            row(&mut g[p * d2..(p + 1) * d2], &pq[k * d2..(k + 1) * d2], c[e]);
        }
        for (e, &(i, k)) in self.b_nz.iter().enumerate() {
            let p = self.pinv[i];
            row(&mut g[p * d2..(p + 1) * d2], &pu[k * d2..(k + 1) * d2], c[na + e]);
        }
        // M⁻¹ = L⁻ᵀ D⁻¹ L⁻¹ in elimination positions.
        let (lv, dv) = c[na + nbz..].split_at(self.l_count);
        let mut l = 0;
        for (p, rows) in self.below.iter().enumerate() {
            for &i in rows {
                let (head, tail) = g.split_at_mut(i * d2);
                row(&mut tail[..d2], &head[p * d2..(p + 1) * d2], -lv[l]);
                l += 1;
            }
        }
        for (p, &d) in dv.iter().enumerate() {
            g[p * d2..(p + 1) * d2].iter_mut().for_each(|v| *v *= d);
        }
        for (p, rows) in self.below.iter().enumerate().rev() {
            l -= rows.len();
            for (x, &i) in rows.iter().enumerate() {
                let (head, tail) = g.split_at_mut(i * d2);
                row(&mut head[p * d2..(p + 1) * d2], &tail[..d2], -lv[l + x]);
            }
        }
        for (p, &k) in self.perm.iter().enumerate() {
            for (o, &v) in bottom[k * d2..(k + 1) * d2].iter_mut().zip(&g[p * d2..(p + 1) * d2]) {
                *o = -v;
            }
        }
    }

    /// Φ(T) from the identity by `scheme` on the instants' grid.
    fn monodromy(&self, inst: &Instants, period: f64, scheme: TreeScheme) -> Vec<f64> {
        let scratch = std::cell::RefCell::new(vec![0.0; 2 * self.n * self.n]);
        self.integrate(inst, period, scheme, |c: &[f64], phi: &Vec<f64>, out: &mut Vec<f64>| {
            self.deriv(c, phi, out, &mut scratch.borrow_mut())
        })
    }

    /// [`TreeSystem::monodromy`] compiled for AVX2: the same operations element by element (no
    /// fused multiply-adds, no reordered sums), so the same results to the bit, on four doubles
    /// at a time instead of SSE2's two (the row operations have length 2n). The derivative's
    /// closure is written here, not taken from `monodromy`, because a closure takes the target
    /// features of the function it is written in.
    #[cfg(target_arch = "x86_64")]
    #[target_feature(enable = "avx2")]
    fn monodromy_avx2(&self, inst: &Instants, period: f64, scheme: TreeScheme) -> Vec<f64> {
        let scratch = std::cell::RefCell::new(vec![0.0; 2 * self.n * self.n]);
        self.integrate(inst, period, scheme, |c: &[f64], phi: &Vec<f64>, out: &mut Vec<f64>| {
            self.deriv(c, phi, out, &mut scratch.borrow_mut())
        })
    }

    /// One period from the identity with the derivative `deriv`: Butcher's method, or RK4 at
    /// steps 2T/N_s and 4T/N_s with Richardson's extrapolation.
    #[inline(always)]
    fn integrate(
        &self,
        inst: &Instants,
        period: f64,
        scheme: TreeScheme,
        deriv: impl Fn(&[f64], &Vec<f64>, &mut Vec<f64>) + Copy,
    ) -> Vec<f64> {
        let d2 = 2 * self.n;
        let at = |j: usize| inst.at(j);
        let mut phi = vec![0.0; d2 * d2];
        for i in 0..d2 {
            phi[i * d2 + i] = 1.0;
        }
        match scheme {
            TreeScheme::Butcher6 { steps } => rk6_period(phi, steps, period, at, deriv),
            TreeScheme::Rk4Richardson => {
                let fine = rk4_period(phi.clone(), inst.ns, 1, period, at, deriv);
                richardson(&fine, &rk4_period(phi, inst.ns, 2, period, at, deriv))
            }
        }
    }
}

/// The tree system's values at the N_s instants: instant j's `[A | B W⁻¹ | L | D]` is
/// `values[j·stride..(j + 1)·stride]`; instants past the period wrap around.
struct Instants<'a> {
    values: &'a [f64],
    stride: usize,
    ns: usize,
}

impl Instants<'_> {
    #[inline(always)]
    fn at(&self, j: usize) -> &[f64] {
        let j = if j >= self.ns { j - self.ns } else { j };
        &self.values[j * self.stride..(j + 1) * self.stride]
    }
}

/// `(16 Φ_h − Φ_2h)/15`: RK4's h⁴ error term removed.
fn richardson(fine: &[f64], coarse: &[f64]) -> Vec<f64> {
    fine.iter().zip(coarse).map(|(f, c)| (16.0 * f - c) / 15.0).collect()
}

/// [`monodromy`] with D × D arrays (D ≥ 2n, even): coordinate k < n of the system is state k,
/// its rate state D/2 + k; the other states have zero coefficients and do not couple. Returns
/// Φ for the steps 2T/N_s and 4T/N_s.
fn monodromy_fixed<const D: usize>(sys: &[f64], n: usize, ns: usize, period: f64) -> (Vec<f64>, Vec<f64>) {
    let (nh, d) = (D / 2, 2 * n);
    let map = |k: usize| if k < n { k } else { nh + k - n };
    // Padded [K | L]: nh rows of D per instant.
    let mut kl = vec![[0.0f64; D]; ns * nh];
    for j in 0..ns {
        for i in 0..n {
            for k in 0..d {
                kl[j * nh + i][map(k)] = sys[j * n * d + i * d + k];
            }
        }
    }
    let deriv = |kl: &[[f64; D]], phi: &[[f64; D]; D], out: &mut [[f64; D]; D]| fixed_deriv(kl, phi, out);
    let at = |j: usize| {
        let j = if j >= ns { j - ns } else { j };
        &kl[j * nh..(j + 1) * nh]
    };
    let rk4 = |stride: usize| {
        let mut phi = [[0.0; D]; D];
        for (i, row) in phi.iter_mut().enumerate() {
            row[i] = 1.0;
        }
        let phi = rk4_period(phi, ns, stride, period, at, deriv);
        let mut out = vec![0.0; d * d];
        for r in 0..d {
            for c in 0..d {
                out[r * d + c] = phi[map(r)][map(c)];
            }
        }
        out
    };
    (rk4(1), rk4(2))
}

/// `out = 𝒜Φ` for [`monodromy_fixed`]: the D/2 rows of `[K | L]` in `kl`.
///
/// NOTE: a function marked to be inlined, not the closure's own body, because the compiler
/// stopped inlining that closure into the RK4 loop when the module around it grew: a call per
/// derivative on the paper's rotor, measured by callgrind (`BENCHMARKS.md`).
#[inline(always)]
fn fixed_deriv<const D: usize>(kl: &[[f64; D]], phi: &[[f64; D]; D], out: &mut [[f64; D]; D]) {
    let nh = D / 2;
    for i in 0..nh {
        out[i] = phi[nh + i];
        let mut o = [0.0; D];
        for (r, p) in kl[i].iter().zip(phi) {
            for c in 0..D {
                o[c] -= r * p[c];
            }
        }
        out[nh + i] = o;
    }
}

/// [`monodromy`] on row-major slices, any size.
fn monodromy_slices(sys: &[f64], n: usize, ns: usize, stride: usize, period: f64) -> Vec<f64> {
    let (d, m2) = (2 * n, 2 * n * n);
    let dd = d * d;
    // The top half of 𝒜Φ is Φ's bottom half, the bottom half −[K | L]Φ, accumulated row by row
    // of Φ so the inner loop runs over contiguous memory.
    let deriv = |kl: &[f64], phi: &Vec<f64>, out: &mut Vec<f64>| {
        let (top, bottom) = out.split_at_mut(n * d);
        top.copy_from_slice(&phi[n * d..]);
        for (row, o) in kl.chunks_exact(d).zip(bottom.chunks_exact_mut(d)) {
            o.fill(0.0);
            for (&r, p) in row.iter().zip(phi.chunks_exact(d)) {
                for (oc, &pc) in o.iter_mut().zip(p) {
                    *oc -= r * pc;
                }
            }
        }
    };
    let mut phi = vec![0.0; dd];
    for i in 0..d {
        phi[i * d + i] = 1.0;
    }
    let at = |j: usize| {
        let j = if j >= ns { j - ns } else { j };
        &sys[j * m2..(j + 1) * m2]
    };
    rk4_period(phi, ns, stride, period, at, deriv)
}

/// A monodromy matrix in one of the two storages: fixed-size rows or a flat row-major vector.
trait Phi: Clone {
    /// `out = x + s y`.
    fn axpy(x: &Self, y: &Self, s: f64, out: &mut Self);
    /// `self += h/6 (k1 + 2 k2 + 2 k3 + k4)`.
    fn rk4_update(&mut self, k: [&Self; 4], h: f64);
}

impl<const D: usize> Phi for [[f64; D]; D] {
    fn axpy(x: &Self, y: &Self, s: f64, out: &mut Self) {
        for r in 0..D {
            for c in 0..D {
                out[r][c] = x[r][c] + s * y[r][c];
            }
        }
    }
    fn rk4_update(&mut self, [k1, k2, k3, k4]: [&Self; 4], h: f64) {
        for r in 0..D {
            for c in 0..D {
                self[r][c] += h / 6.0 * (k1[r][c] + 2.0 * k2[r][c] + 2.0 * k3[r][c] + k4[r][c]);
            }
        }
    }
}

impl Phi for Vec<f64> {
    #[inline(always)]
    fn axpy(x: &Self, y: &Self, s: f64, out: &mut Self) {
        axpy(x, y, s, out);
    }
    #[inline(always)]
    fn rk4_update(&mut self, [k1, k2, k3, k4]: [&Self; 4], h: f64) {
        for ((((p, &a), &b), &c), &e) in self.iter_mut().zip(k1).zip(k2).zip(k3).zip(k4) {
            *p += h / 6.0 * (a + 2.0 * b + 2.0 * c + e);
        }
    }
}

/// RK4 for `Φ' = 𝒜(t) Φ` over one period T from `phi`, with step 2T·stride/N_s: the stages of a
/// step from instant j read the coefficients `at(j)`, `at(j + stride)` (twice) and
/// `at(j + 2 stride)`; `deriv(coefficients, Φ, out)` writes 𝒜Φ. Inlined, so that it takes the
/// target features of its caller (`TreeSystem::monodromy_avx2`).
#[inline(always)]
fn rk4_period<'a, T: Phi, C: ?Sized + 'a>(
    mut phi: T,
    ns: usize,
    stride: usize,
    period: f64,
    at: impl Fn(usize) -> &'a C,
    deriv: impl Fn(&C, &T, &mut T),
) -> T {
    let h = 2.0 * stride as f64 * period / ns as f64;
    let (mut k1, mut k2, mut k3, mut k4, mut tmp) = (phi.clone(), phi.clone(), phi.clone(), phi.clone(), phi.clone());
    for step in 0..ns / (2 * stride) {
        let j = 2 * stride * step;
        let (a0, a1, a2) = (at(j), at(j + stride), at(j + 2 * stride));
        deriv(a0, &phi, &mut k1);
        T::axpy(&phi, &k1, 0.5 * h, &mut tmp);
        deriv(a1, &tmp, &mut k2);
        T::axpy(&phi, &k2, 0.5 * h, &mut tmp);
        deriv(a1, &tmp, &mut k3);
        T::axpy(&phi, &k3, h, &mut tmp);
        deriv(a2, &tmp, &mut k4);
        phi.rk4_update([&k1, &k2, &k3, &k4], h);
    }
    phi
}

/// Nodes of Butcher's seven-stage, sixth-order explicit Runge–Kutta method in sixths of a step
/// (c = 0, 1/3, 2/3, 1/3, 1/2, 1/2, 1), its coefficients a_ij (row i: the stage's combination of
/// the earlier stages) and its weights b (J. C. Butcher, *Numerical Methods for Ordinary
/// Differential Equations*, 2nd ed., Wiley 2008, §325; order checked by a unit test).
const BUTCHER6_C: [usize; 7] = [0, 2, 4, 2, 3, 3, 6];
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
/// [`rk4_period`]. Inlined, so that it takes the target features of its caller.
#[inline(always)]
fn rk6_period<'a, C: ?Sized + 'a>(
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

/// `out = x + s y`.
#[inline(always)]
fn axpy(x: &[f64], y: &[f64], s: f64, out: &mut [f64]) {
    for ((o, &a), &b) in out.iter_mut().zip(x).zip(y) {
        *o = a + s * b;
    }
}

/// Solves `C X = R` in place (C n×n, R n×m, both row-major; R becomes X) by Gaussian elimination
/// with partial pivoting. False when C is singular.
fn solve_in_place(c: &mut [f64], r: &mut [f64], n: usize, m: usize) -> bool {
    for col in 0..n {
        let piv = (col..n).max_by(|&a, &b| c[a * n + col].abs().total_cmp(&c[b * n + col].abs())).unwrap_or(col);
        if c[piv * n + col] == 0.0 || !c[piv * n + col].is_finite() {
            return false;
        }
        if piv != col {
            for k in 0..n {
                c.swap(piv * n + k, col * n + k);
            }
            for k in 0..m {
                r.swap(piv * m + k, col * m + k);
            }
        }
        let p = c[col * n + col];
        for row in col + 1..n {
            let f = c[row * n + col] / p;
            if f == 0.0 {
                continue;
            }
            for k in col..n {
                c[row * n + k] -= f * c[col * n + k];
            }
            for k in 0..m {
                r[row * m + k] -= f * r[col * m + k];
            }
        }
    }
    for col in (0..n).rev() {
        let p = c[col * n + col];
        for k in 0..m {
            let mut v = r[col * m + k];
            for j in col + 1..n {
                v -= c[col * n + j] * r[j * m + k];
            }
            r[col * m + k] = v / p;
        }
    }
    true
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
        let tight = super::super::HbmOptions { stability_samples: 2048, ..Default::default() };
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
        let opts = super::super::HbmOptions { harmonics: 5, ..Default::default() };
        let mut hbm = Hbm::new(&kane, spin, omega, &h, opts).unwrap();
        assert_eq!(hbm.n, 7);
        let tight = super::super::HbmOptions { harmonics: 5, stability_samples: 4096, ..Default::default() };
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

    /// The AVX2 build of the tree monodromy gives the plain build's results to the bit (the same
    /// operations element by element), on an arrow of 4 leaves and a root with arbitrary
    /// values: the multipliers do not depend on the processor they are computed on.
    #[cfg(target_arch = "x86_64")]
    #[test]
    fn the_avx2_monodromy_is_the_plain_one_to_the_bit() {
        if !std::arch::is_x86_feature_detected!("avx2") {
            return;
        }
        let n = 5;
        let arrow: Vec<(usize, usize)> =
            (0..n).flat_map(|i| (0..n).map(move |k| (i, k))).filter(|&(i, k)| i == k || i == 4 || k == 4).collect();
        let system = TreeSystem {
            n,
            winv_nz: (0..n).map(|i| (i, i, 1.0 + 0.1 * i as f64)).chain([(1, 4, -0.3)]).collect(),
            a_nz: arrow.clone(),
            b_nz: arrow.clone(),
            pinv: (0..n).collect(),
            perm: (0..n).collect(),
            below: (0..n).map(|p| if p < 4 { vec![4] } else { Vec::new() }).collect(),
            na: arrow.len(),
            nbz: arrow.len(),
            l_count: 4,
        };
        let value = |i: usize| ((i * 7919 % 101) as f64 / 101.0 - 0.5) * 1.7;
        // Twelve instants of [A | B W⁻¹ | L | D⁻¹], D positive.
        let (ns, stride) = (12, 2 * arrow.len() + 4 + n);
        let values: Vec<f64> =
            (0..ns * stride).map(|e| if e % stride >= stride - n { 1.0 + value(e).abs() } else { value(e) }).collect();
        let inst = Instants { values: &values, stride, ns };
        // Both schemes: Butcher's in two steps, RK4 with Richardson on the twelve instants.
        for scheme in [TreeScheme::Butcher6 { steps: 2 }, TreeScheme::Rk4Richardson] {
            let plain = system.monodromy(&inst, 0.9, scheme);
            // SAFETY: the processor has AVX2 (checked above).
            let wide = unsafe { system.monodromy_avx2(&inst, 0.9, scheme) };
            let bits = |v: &[f64]| v.iter().map(|x| x.to_bits()).collect::<Vec<_>>();
            assert_eq!(bits(&plain), bits(&wide), "{scheme:?}");
            assert!(plain.iter().any(|v| *v != 0.0 && *v != 1.0));
        }
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

    /// The Hessenberg LU solves `(H − s I) x = b` to rounding (residual below 1e-13 relative)
    /// when its pivoting swaps rows: the subdiagonal of this H exceeds its diagonal.
    #[test]
    fn hessenberg_lu_solves_with_row_swaps() {
        let d = 6;
        let h = DMatrix::from_fn(d, d, |i, j| {
            if i == j + 1 {
                2.0 + i as f64
            } else if i <= j {
                ((i * 5 + j * 3) % 7) as f64 * 0.1 - 0.3
            } else {
                0.0
            }
        });
        let s = Complex::new(0.05, 0.02);
        let lu = HessenbergLu::new(&h, s).unwrap();
        assert!(lu.swapped.iter().filter(|&&x| x).count() >= 3, "{:?}", lu.swapped);
        let b = DVector::from_fn(d, |i, _| Complex::new(1.0 + i as f64, -0.5 * i as f64));
        let x = lu.solve(&b).unwrap();
        let a = DMatrix::from_fn(d, d, |i, j| {
            Complex::new(h[(i, j)], 0.0) - if i == j { s } else { Complex::new(0.0, 0.0) }
        });
        let r = (&a * &x - &b).norm() / b.norm();
        println!("{} swaps, residual {r:.1e}", lu.swapped.iter().filter(|&&x| x).count());
        assert!(r <= 1e-13, "{r:e}");
    }

    /// The fixed-size (and padded) monodromy equals the slice version on arbitrary coefficients.
    #[test]
    fn fixed_size_monodromy_equals_the_slice_version() {
        for n in 1..=6 {
            let (ns, d) = (16, 2 * n);
            // A deterministic, non-symmetric, time-varying [K | L].
            let sys: Vec<f64> =
                (0..ns * n * d).map(|i| ((i * 7919 % 97) as f64 / 97.0 - 0.5) * (1.0 + (i % 5) as f64)).collect();
            let a = monodromy(&sys, n, ns, 0.7);
            let b = richardson(&monodromy_slices(&sys, n, ns, 1, 0.7), &monodromy_slices(&sys, n, ns, 2, 0.7));
            let scale = b.iter().fold(0.0f64, |m, v| m.max(v.abs()));
            let e = a.iter().zip(&b).fold(0.0f64, |m, (x, y)| m.max((x - y).abs()));
            assert!(e <= 1e-13 * scale, "n = {n}: {e:e} of {scale:e}");
        }
    }
}
