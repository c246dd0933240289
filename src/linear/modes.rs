//! Eigen-analysis of the linearised mechanism ([`LinearModel::modes`]): the eigenvalues of the
//! reduced state matrix `ẋ_r = S x_r` (eq. 19, `M ẋ + A x = 0`, solved for ẋ with the cyclic spin
//! angle θ* removed, and the spin speed removed too when it is held, eq. 14), by balancing
//! (Parlett–Reinsch) and the real Schur form; each mode's shape as the right singular vector of
//! `S − λI` with the smallest singular value (the next ones for a repeated root). The modes are
//! classified (spin angle, spin speed, vibration: see the module docs of [`crate::linear`]),
//! scaled, and given eigen-orders |Im λ|/Ω, damping ratios, coordinate shares and kinetic-energy
//! shares per body. For the CPVA the held spin gives the pendulum's tuning order n_t (eq. 15).

use super::{C64, Damping, LinResult, LinearError, LinearModel, Spin};
use nalgebra::DMatrix;
use std::f64::consts::PI;

/// An eigenvalue counts as real when `|Im λ| ≤ REAL_TOL · scale` (scale: the largest |λ| or Ω).
const REAL_TOL: f64 = 1e-10;
/// Eigenvalues closer than `REPEAT_TOL · scale` share a null space (repeated roots, e.g. the
/// non-unison pendulum modes of N identical pendulums); they get distinct null vectors.
const REPEAT_TOL: f64 = 1e-7;

/// What a mode is.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum ModeKind {
    /// Rigid rotation of the whole spinning mechanism by a constant angle (λ = 0 exactly).
    SpinAngle,
    /// Rigid change of spin speed (λ = 0 without losses, ≈ −c_r/J with them).
    SpinSpeed,
    /// A vibration mode (one per remaining degree of freedom; zero-frequency ones included, e.g. a
    /// pendulum at Ω = 0).
    Vibration,
}

/// One mode of the linearised mechanism.
#[derive(Debug, Clone, PartialEq)]
pub struct Mode {
    /// What it is.
    pub kind: ModeKind,
    /// Its eigenvalue λ (rad/s), with Im λ ≥ 0; for a pair of real eigenvalues (an overdamped
    /// or zero-frequency mode) the one of smaller modulus.
    pub eigenvalue: C64,
    /// The other eigenvalue of the mode: the conjugate, or the other real one.
    pub partner: C64,
    /// Undamped natural frequency ω_n = |λ| (= sqrt(λ₁λ₂) for a real pair), rad/s.
    pub natural_frequency_rad_s: f64,
    /// Damped frequency |Im λ|, rad/s.
    pub damped_frequency_rad_s: f64,
    /// Damped frequency in Hz.
    pub frequency_hz: f64,
    /// Eigen-order |Im λ| / Ω (NaN at Ω = 0).
    pub order: f64,
    /// Damping ratio −Re λ / |λ| (−(λ₁+λ₂)/(2ω_n) for a real pair; NaN when ω_n = 0).
    pub damping_ratio: f64,
    /// Shape in the coordinates q (n entries, joint order), scaled so that the largest entry of
    /// `shape_qdot` is 1 (for a zero-frequency vibration mode, where q̇ = λq vanishes, the
    /// largest entry of `shape_q` is 1 instead). For the spin-speed mode the spin angle entry is
    /// left at 0 (it grows linearly in time there).
    pub shape_q: Vec<C64>,
    /// Shape in the joint rates q̇ = W⁻¹u (= λ·shape_q), largest entry 1.
    pub shape_qdot: Vec<C64>,
    /// Shape in the speeds u of the mechanism, same scaling.
    pub shape_u: Vec<C64>,
    /// Share of each coordinate, `|q̇_j|² (M_q)_jj` normalised to sum 1 (the diagonal part of
    /// the kinetic energy; independent of the speeds choice; `|q_j|²` in place of `|q̇_j|²` for
    /// a zero-frequency mode).
    pub coordinate_share: Vec<f64>,
    /// Share of each body in the mode's kinetic energy `½(m|v|² + I|ω|²)` (sum 1; all 0 for the
    /// spin-angle mode, which has no velocity).
    pub body_energy_share: Vec<f64>,
    /// Share of each coordinate in the mode's potential energy, `K_jj |q_j|²` normalised to sum
    /// 1 with `K = −Wᵀ F_q` (spring stiffness, and the centrifugal stiffness of a pendulum): where
    /// the mode twists the mechanism. All 0 when no coordinate is stiff in the mode (a rigid or
    /// zero-frequency mode).
    pub strain_share: Vec<f64>,
    /// Name of the joint that holds most of the mode's potential energy (the largest
    /// `strain_share`: the shaft or spring a drivetrain mode twists, the pivot of an absorber);
    /// the joint of the largest coordinate share when no joint is stiff in the mode.
    pub label: String,
}

/// The eigen-analysis of a linear model.
#[derive(Debug, Clone, PartialEq)]
pub struct Modal {
    /// Spin speed Ω, rad/s.
    pub omega: f64,
    /// Spin free or held.
    pub spin: Spin,
    /// Dampers kept or removed.
    pub damping: Damping,
    /// Joint names (coordinate order).
    pub joints: Vec<String>,
    /// Body names.
    pub bodies: Vec<String>,
    /// Rigid-body modes of the free spin (spin angle, spin speed); empty when held.
    pub rigid: Vec<Mode>,
    /// Vibration modes (n − 1 of them), by increasing natural frequency.
    pub modes: Vec<Mode>,
    /// True when no eigenvalue has a positive real part (beyond rounding).
    pub stable: bool,
}

impl LinearModel {
    /// Kept coordinate and speed indices of the reduced state (the spin angle is always dropped:
    /// cyclic).
    fn kept(&self, spin: Spin) -> (Vec<usize>, Vec<usize>) {
        let s = self.op.spin_coordinate;
        let qi: Vec<usize> = (0..self.ndof()).filter(|&j| j != s).collect();
        let ui = match spin {
            Spin::Free => (0..self.ndof()).collect(),
            Spin::Held => qi.clone(),
        };
        (qi, ui)
    }

    /// The reduced state matrix `ẋ_r = S x_r`, `x_r = [q_qi; u_ui]`.
    fn state_matrix(&self, spin: Spin, damping: Damping) -> LinResult<(DMatrix<f64>, Vec<usize>, Vec<usize>)> {
        let (qi, ui) = self.kept(spin);
        let (nq, nu) = (qi.len(), ui.len());
        let chol = select(&self.mass, &ui, &ui)
            .cholesky()
            .ok_or_else(|| LinearError::MassMatrix { mechanism: self.mech.name.clone() })?;
        // The kept angles are the deviations from the rigid rotation, `p_j = q*_j − z_j θ*`
        // (`p = q*` off a geared train, where z_j = 0): θ* drops out of every equation because
        // F_q z = 0, and `ṗ_j = (W⁻¹u)_j − z_j (W⁻¹u)_s`.
        let s_row = self.w_inv.row(self.op.spin_coordinate).clone_owned();
        let mut w_p = self.w_inv.clone();
        for (j, &z) in self.op.rotation.iter().enumerate() {
            if j != self.op.spin_coordinate && z != 0.0 {
                let row = w_p.row(j) - &s_row * z;
                w_p.set_row(j, &row);
            }
        }
        let mut s = DMatrix::zeros(nq + nu, nq + nu);
        s.view_mut((0, nq), (nq, nu)).copy_from(&select(&w_p, &qi, &ui));
        s.view_mut((nq, 0), (nu, nq)).copy_from(&chol.solve(&select(&self.f_q, &ui, &qi)));
        s.view_mut((nq, nq), (nu, nu)).copy_from(&chol.solve(&select(self.f_u_of(damping), &ui, &ui)));
        Ok((s, qi, ui))
    }

    /// The largest eigenvalue modulus |λ| (1/s) of [`LinearModel::modes`] for the same choices,
    /// without the mode shapes: the eigenvalues alone, those within `REAL_TOL` of the real axis
    /// counted by their real part as `modes` reports them, the complex ones by their modulus.
    /// Equal to the largest `max(|eigenvalue|, |partner|)` over `modes`' rigid and vibration
    /// modes, and fails where `modes` does.
    ///
    /// NOTE: a time run's step bound needs only this number; the shapes' singular value
    /// decompositions (one per mode) were most of the set-up of a 32-pendulum sweep
    /// (BENCHMARKS.md).
    pub fn fastest_rate(&self, spin: Spin, damping: Damping) -> LinResult<f64> {
        let (sm, _, _) = self.state_matrix(spin, damping)?;
        let lambdas = eigenvalues(&sm)?;
        let scale = lambdas.iter().map(|l| l.norm()).fold(self.op.omega.abs(), f64::max).max(f64::MIN_POSITIVE);
        let is_real = |l: &C64| l.im.abs() <= REAL_TOL * scale;
        Ok(lambdas
            .iter()
            .filter_map(|l| if is_real(l) { Some(l.re.abs()) } else { (l.im > 0.0).then(|| l.norm()) })
            .fold(0.0, f64::max))
    }

    /// Eigen-analysis: rigid-body modes of the free spin and the n − 1 vibration modes with
    /// eigen-orders, damping ratios, shapes and participation (see [`Mode`]).
    pub fn modes(&self, spin: Spin, damping: Damping) -> LinResult<Modal> {
        let n = self.ndof();
        let s = self.op.spin_coordinate;
        let omega = self.op.omega;
        let (sm, qi, ui) = self.state_matrix(spin, damping)?;
        let lambdas = eigenvalues(&sm)?;
        let scale = lambdas.iter().map(|l| l.norm()).fold(omega.abs(), f64::max).max(f64::MIN_POSITIVE);
        let picks = pick_roots(&lambdas, scale, spin);
        let second = self.second_order(damping);
        let (mq, kq) = (&second.m, &second.k);
        // The joint that owns each coordinate names the modes.
        let joints: Vec<String> = (0..n).map(|k| self.mech.joints[self.mech.joint_of(k)].name.clone()).collect();
        let bodies: Vec<String> = self.mech.bodies.iter().map(|b| b.name.clone()).collect();
        let mut rigid = Vec::new();
        let mut modes = Vec::new();
        if spin == Spin::Free {
            rigid.push(self.spin_angle_mode(mq, &joints));
        }
        let mut used: Vec<C64> = Vec::new();
        for (rep, partner, kind) in picks {
            let k = used.iter().filter(|u| (**u - rep).norm() <= REPEAT_TOL * scale).count();
            used.push(rep);
            let shape = self.mode_shape(&sm, (&qi, &ui), rep, k, kind == ModeKind::Vibration && spin == Spin::Free);
            let mode = self.mode_from_shape(shape, (rep, partner, kind), scale, (mq, kq), &joints);
            if kind == ModeKind::SpinSpeed {
                let mut mode = mode;
                mode.shape_q[s] = C64::new(0.0, 0.0);
                mode.label = joints[s].clone();
                rigid.push(mode);
            } else {
                modes.push(mode);
            }
        }
        modes.sort_by(|a, b| a.natural_frequency_rad_s.total_cmp(&b.natural_frequency_rad_s));
        let stable = lambdas.iter().all(|l| l.re <= 1e-9 * scale);
        Ok(Modal { omega, spin, damping, joints, bodies, rigid, modes, stable })
    }

    /// The rigid rotation of the free spin (λ = 0): the rotation pattern `z` as its shape.
    fn spin_angle_mode(&self, mq: &DMatrix<f64>, joints: &[String]) -> Mode {
        let n = self.ndof();
        let nb = self.mech.bodies.len();
        let shape_q: Vec<C64> = self.op.rotation.iter().map(|&z| C64::new(z, 0.0)).collect();
        let mut share: Vec<f64> = (0..n).map(|j| self.op.rotation[j].powi(2) * mq[(j, j)]).collect();
        normalise(&mut share);
        Mode {
            kind: ModeKind::SpinAngle,
            eigenvalue: C64::new(0.0, 0.0),
            partner: C64::new(0.0, 0.0),
            natural_frequency_rad_s: 0.0,
            damped_frequency_rad_s: 0.0,
            frequency_hz: 0.0,
            order: 0.0,
            damping_ratio: f64::NAN,
            shape_q,
            shape_qdot: vec![C64::new(0.0, 0.0); n],
            shape_u: vec![C64::new(0.0, 0.0); n],
            coordinate_share: share,
            body_energy_share: vec![0.0; nb],
            strain_share: vec![0.0; n],
            label: joints[self.op.spin_coordinate].clone(),
        }
    }

    /// The shape `(q, u, q̇)` of the mode at root `rep`: the k-th null vector of `S − λI` over
    /// the kept coordinates and speeds `kept`, unscaled. With `free_vibration` (a vibration
    /// mode of the free spin) the spin angle and the rotation pattern are put back.
    fn mode_shape(
        &self,
        sm: &DMatrix<f64>,
        kept: (&[usize], &[usize]),
        rep: C64,
        k: usize,
        free_vibration: bool,
    ) -> (Vec<C64>, Vec<C64>, Vec<C64>) {
        let n = self.ndof();
        let s = self.op.spin_coordinate;
        let (qi, ui) = kept;
        let v = null_vector(sm, rep, k);
        let nq = qi.len();
        let mut q = vec![C64::new(0.0, 0.0); n];
        let mut u = vec![C64::new(0.0, 0.0); n];
        for (a, &j) in qi.iter().enumerate() {
            q[j] = v[a];
        }
        for (a, &j) in ui.iter().enumerate() {
            u[j] = v[nq + a];
        }
        if free_vibration && rep.norm() > 0.0 {
            // θ̇* = u_s*: the spin angle's part of the eigenvector.
            q[s] = u[s] / rep;
            // Back from the deviations p to the coordinates: q*_j = p_j + z_j θ*.
            let theta = q[s];
            for (j, &z) in self.op.rotation.iter().enumerate() {
                if j != s {
                    q[j] += z * theta;
                }
            }
        }
        let mut qdot = vec![C64::new(0.0, 0.0); n];
        for k in 0..n {
            for r in 0..n {
                qdot[k] += u[r] * self.w_inv[(k, r)];
            }
        }
        (q, u, qdot)
    }

    /// The mode at `root = (rep, partner, kind)` from its unscaled shape: scaled, with its
    /// coordinate, kinetic-energy and strain shares, frequencies, damping ratio and label.
    fn mode_from_shape(
        &self,
        shape: (Vec<C64>, Vec<C64>, Vec<C64>),
        root: (C64, C64, ModeKind),
        scale: f64,
        (mq, kq): (&DMatrix<f64>, &DMatrix<f64>),
        joints: &[String],
    ) -> Mode {
        let n = self.ndof();
        let omega = self.op.omega;
        let (rep, partner, kind) = root;
        let (mut q, mut u, mut qdot) = shape;
        // Scale: largest q̇ entry made 1; for a zero-frequency mode (q̇ = λq ≈ 0, only rounding
        // left in q̇) the displacement q stands in for q̇ in the scaling and the shares.
        let moving = rep.norm() > REPEAT_TOL * scale || kind == ModeKind::SpinSpeed;
        let basis = if moving { &qdot } else { &q };
        let pivot = basis
            .iter()
            .copied()
            .max_by(|a, b| a.norm().total_cmp(&b.norm()))
            .filter(|p| p.norm() > 0.0)
            .unwrap_or(C64::new(1.0, 0.0));
        for x in q.iter_mut().chain(u.iter_mut()).chain(qdot.iter_mut()) {
            *x /= pivot;
        }
        let basis = if moving { &qdot } else { &q };
        let mut share: Vec<f64> = (0..n).map(|j| basis[j].norm_sqr() * mq[(j, j)]).collect();
        normalise(&mut share);
        let energy = self.kinetic_shares(&u);
        let (strain, stiff) = strain_shares(kq, &q);
        let argmax = |v: &[f64]| v.iter().enumerate().max_by(|a, b| a.1.total_cmp(b.1)).map_or(0, |(j, _)| j);
        let top = if stiff { argmax(&strain) } else { argmax(&share) };
        // A compliant mesh (or a shaft between two meshes) holds its strain between two
        // coordinates: it names the mode when it holds more than any coordinate's own spring.
        let label = if stiff { self.strain_label(&q, kq, joints) } else { joints[top].clone() };
        let (wn, zeta) = if rep.im != 0.0 {
            (rep.norm(), if rep.norm() > 0.0 { -rep.re / rep.norm() } else { f64::NAN })
        } else {
            let wn = (rep.re * partner.re).abs().sqrt();
            (wn, if wn > 0.0 { -(rep.re + partner.re) / (2.0 * wn) } else { f64::NAN })
        };
        let wd = rep.im.abs();
        Mode {
            kind,
            eigenvalue: rep,
            partner,
            natural_frequency_rad_s: wn,
            damped_frequency_rad_s: wd,
            frequency_hz: wd / (2.0 * PI),
            order: if omega != 0.0 { wd / omega.abs() } else { f64::NAN },
            damping_ratio: zeta,
            shape_q: q,
            shape_qdot: qdot,
            shape_u: u,
            coordinate_share: share,
            body_energy_share: energy,
            strain_share: strain,
            label,
        }
    }

    /// Each body's share of the mode's kinetic energy, from the speeds' shape `u`.
    fn kinetic_shares(&self, u: &[C64]) -> Vec<f64> {
        let n = self.ndof();
        let nb = self.mech.bodies.len();
        let mut energy: Vec<f64> = (0..nb)
            .map(|j| {
                let (pv, pw) = &self.partials[j];
                let (mut vx, mut vy, mut w) = (C64::new(0.0, 0.0), C64::new(0.0, 0.0), C64::new(0.0, 0.0));
                for r in 0..n {
                    vx += u[r] * pv[r].x;
                    vy += u[r] * pv[r].y;
                    w += u[r] * pw[r];
                }
                let b = &self.mech.bodies[j].inertia;
                0.5 * (b.mass * (vx.norm_sqr() + vy.norm_sqr()) + b.i_com * w.norm_sqr())
            })
            .collect();
        normalise(&mut energy);
        energy
    }
}

/// The roots that make modes, each as (representative, partner, kind): with a free spin the real
/// root nearest 0 is the spin speed; each complex pair (Im λ > 0 representing it) and each pair
/// of the remaining real roots (sorted, the smaller in magnitude representing) is a vibration.
fn pick_roots(lambdas: &[C64], scale: f64, spin: Spin) -> Vec<(C64, C64, ModeKind)> {
    let is_real = |l: &C64| l.im.abs() <= REAL_TOL * scale;
    let mut reals: Vec<f64> = lambdas.iter().filter(|l| is_real(l)).map(|l| l.re).collect();
    reals.sort_by(f64::total_cmp);
    let mut picks: Vec<(C64, C64, ModeKind)> = Vec::new();
    if spin == Spin::Free
        && let Some((i, _)) = reals.iter().enumerate().min_by(|a, b| a.1.abs().total_cmp(&b.1.abs()))
    {
        let l = reals.remove(i);
        picks.push((C64::new(l, 0.0), C64::new(l, 0.0), ModeKind::SpinSpeed));
    }
    for l in lambdas.iter().filter(|l| !is_real(l) && l.im > 0.0) {
        picks.push((*l, l.conj(), ModeKind::Vibration));
    }
    for pair in reals.chunks(2) {
        let (a, b) = (pair[0], *pair.get(1).unwrap_or(&pair[0]));
        let (rep, other) = if a.abs() <= b.abs() { (a, b) } else { (b, a) };
        picks.push((C64::new(rep, 0.0), C64::new(other, 0.0), ModeKind::Vibration));
    }
    picks
}

/// Potential energy by coordinate (the diagonal part: a tree's springs and pendulums each sit on
/// their own coordinate), normalised, and whether it is positive overall. A mode whose diagonal
/// potential energy is not (a pendulum standing inward, a rigid mode) gets zeros and is named
/// by its kinetic share instead.
fn strain_shares(kq: &DMatrix<f64>, q: &[C64]) -> (Vec<f64>, bool) {
    let n = q.len();
    let mut strain: Vec<f64> = (0..n).map(|j| kq[(j, j)] * q[j].norm_sqr()).collect();
    let stiff = strain.iter().sum::<f64>() > 0.0;
    strain.iter_mut().for_each(|e| *e = e.max(0.0));
    if stiff {
        normalise(&mut strain);
    } else {
        strain.fill(0.0);
    }
    (strain, stiff)
}

impl LinearModel {
    /// The element holding most of a mode's potential energy: a coordinate by its diagonal
    /// stiffness less its meshes' share (`(K_jj − Σ k v_j²)|q_j|²`), or a compliant mesh by
    /// `k|e|²`, e its deflection `q_follows − q_joint/ratio` through the follow map; a mesh is
    /// named `mesh <joint>/<follows>`.
    fn strain_label(&self, q: &[C64], kq: &DMatrix<f64>, joints: &[String]) -> String {
        let mech = &self.mech;
        let map = mech.follow_map();
        let mut own: Vec<f64> = (0..q.len()).map(|j| kq[(j, j)]).collect();
        let mut best: Option<(f64, String)> = None;
        for g in &mech.gears {
            let (Some(m), Some(fj), Some(ff)) = (g.mesh, map[g.joint], map[g.follows]) else { continue };
            let mut v: Vec<(usize, f64)> = vec![(ff.coordinate, ff.factor), (fj.coordinate, -fj.factor / g.ratio)];
            if v[0].0 == v[1].0 {
                v = vec![(v[0].0, v[0].1 + v[1].1)];
            }
            let e: C64 = v.iter().map(|&(c, a)| q[c] * a).sum();
            for &(c, a) in &v {
                own[c] -= m.stiffness * a * a;
            }
            let energy = m.stiffness * e.norm_sqr();
            if best.as_ref().is_none_or(|b| energy > b.0) {
                best = Some((energy, format!("mesh {}/{}", mech.joints[g.joint].name, mech.joints[g.follows].name)));
            }
        }
        let (j, top) = own
            .iter()
            .zip(q)
            .map(|(k, x)| k * x.norm_sqr())
            .enumerate()
            .max_by(|a, b| a.1.total_cmp(&b.1))
            .unwrap_or((0, 0.0));
        match best {
            Some((e, name)) if e > top => name,
            _ => joints[j].clone(),
        }
    }
}

/// The submatrix of `m` on `rows` × `cols`.
fn select(m: &DMatrix<f64>, rows: &[usize], cols: &[usize]) -> DMatrix<f64> {
    DMatrix::from_fn(rows.len(), cols.len(), |i, j| m[(rows[i], cols[j])])
}

/// Scales `v` to sum 1 (left alone when the sum is not positive).
fn normalise(v: &mut [f64]) {
    let s: f64 = v.iter().sum();
    if s > 0.0 {
        v.iter_mut().for_each(|x| *x /= s);
    }
}

/// Eigenvalues of a real square matrix: balanced (Parlett–Reinsch), then real Schur form.
fn eigenvalues(s: &DMatrix<f64>) -> LinResult<Vec<C64>> {
    let d = s.nrows();
    match d {
        0 => return Ok(Vec::new()),
        1 => return Ok(vec![C64::new(s[(0, 0)], 0.0)]),
        _ => {}
    }
    let mut b = s.clone();
    nalgebra::linalg::balancing::balance_parlett_reinsch(&mut b);
    let schur = nalgebra::Schur::try_new(b, f64::EPSILON, 100_000).ok_or(LinearError::Eigen { dim: d })?;
    Ok(schur.complex_eigenvalues().iter().copied().collect())
}

/// The right singular vector of `S − λI` with the (k+1)-th smallest singular value: the
/// eigenvector for k = 0, further null vectors of a repeated eigenvalue for k ≥ 1.
fn null_vector(s: &DMatrix<f64>, lambda: C64, k: usize) -> Vec<C64> {
    let d = s.nrows();
    let a = DMatrix::from_fn(d, d, |i, j| C64::new(s[(i, j)], 0.0) - if i == j { lambda } else { C64::new(0.0, 0.0) });
    let Ok(svd) = super::bounded::svd(a, false, true) else {
        return vec![C64::new(0.0, 0.0); d];
    };
    let Some(vt) = svd.v_t else {
        return vec![C64::new(0.0, 0.0); d];
    };
    let mut order: Vec<usize> = (0..svd.singular_values.len()).collect();
    order.sort_by(|&a, &b| svd.singular_values[a].total_cmp(&svd.singular_values[b]));
    let row = order[k.min(d - 1)];
    (0..d).map(|j| vt[(row, j)].conj()).collect()
}
