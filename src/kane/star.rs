//! The right-hand side of a rotor carrying many pendulums in one pass per stage: absolute
//! angular velocities, speed 0 a root spinning on the ground, every other speed a revolute leaf
//! pivoted on it (`Model::star_rhs`).
//!
//! Method: the pair form of [`super::absolute`] (`M_0j = α_j cos φ_j − β_j sin φ_j`,
//! `D_j = α_j sin φ_j + β_j cos φ_j`, constant diagonal) with the leaves-first factorisation of
//! [`super::tree`] written out for this tree: eliminating leaf j subtracts `M_0j²/M_jj` from the
//! root's pivot and `M_0j F_j/M_jj` from its right-hand side, and then
//! `u̇_j = (F_j − M_0j u̇_0)/M_jj`. The leaves' constants are packed per quantity at build, so
//! each pass is a loop over arrays that the compiler vectorises (four lanes where AVX2 is
//! detected at run time); the root's sums are taken in four interleaved partial sums, which
//! changes their rounding against the general path (to about 1e-15 of u̇, tested against the
//! dense LDLᵀ in `tests/it/random_trees.rs`) but not between machines with and without AVX2.

use super::{GROUND_PARENT, Model, PIVOT_TOL, Workspace};
use crate::error::EngineError;
use crate::model::sincos::sin_cos_many;

/// The packed constants of a rotor and its leaves (index j = 1..n; entry 0 unused).
#[derive(Debug, Clone)]
pub(super) struct Star {
    alpha: Vec<f64>,
    beta: Vec<f64>,
    k_spring: Vec<f64>,
    q_free: Vec<f64>,
    c_joint: Vec<f64>,
    c_ground: Vec<f64>,
    /// 1/M_jj.
    d_inv: Vec<f64>,
    /// The root's M_00 and the pivots' scale (the largest diagonal entry).
    diag0: f64,
    scale: f64,
}

impl Model {
    /// The packed constants when [`Model::rhs_star`] applies: the pair form without gravity,
    /// point forces or couplings, more than six speeds, speed 0 a root and every other body a
    /// leaf hanging from it, and the leaves' constant pivots positive.
    pub(super) fn star_rhs(&self) -> Option<Star> {
        let n = self.n;
        let gravity = self.world && self.gravity != crate::model::math::Vec2::zeros();
        if n <= 6
            || self.nb != n
            || self.form != super::Form::Pairs
            || gravity
            || !self.point_forces.is_empty()
            || !self.couplings.is_empty()
            || self.nodes[0].parent != GROUND_PARENT
            || self.pairs.len() != n - 1
            || self.nodes[1..n].iter().any(|nd| nd.parent != 0)
        {
            return None;
        }
        let scale = self.nodes[..n].iter().fold(0.0f64, |s, nd| s.max(nd.diag_abs.abs()));
        if self.nodes[1..n].iter().any(|nd| !(nd.diag_abs > PIVOT_TOL * scale)) {
            return None;
        }
        let per = |f: &dyn Fn(usize) -> f64| (0..n).map(|j| if j == 0 { 0.0 } else { f(j) }).collect::<Vec<_>>();
        let nd = &self.nodes;
        Some(Star {
            alpha: per(&|j| self.pairs[j - 1].0),
            beta: per(&|j| self.pairs[j - 1].1),
            k_spring: per(&|j| nd[j].k_spring),
            q_free: per(&|j| nd[j].q_free),
            c_joint: per(&|j| nd[j].c_joint),
            c_ground: per(&|j| nd[j].c_ground),
            d_inv: per(&|j| 1.0 / nd[j].diag_abs),
            diag0: nd[0].diag_abs,
            scale,
        })
    }

    /// `Kane::rhs` for a rotor carrying leaves ([`Model::star_rhs`]; see the module doc).
    pub(super) fn rhs_star(
        &self,
        star: &Star,
        ws: &mut Workspace,
        t: f64,
        x: &[f64],
        xdot: &mut [f64],
    ) -> Result<(), EngineError> {
        let n = self.n;
        let (q, u) = x.split_at(n);
        let (qd, ud) = xdot.split_at_mut(n);
        let (sin, cos) = (&mut ws.sin[1..n], &mut ws.cos[1..n]);
        sin_cos_many(&q[1..], sin, cos);
        let (f, v) = (&mut ws.f[..n], &mut ws.row[..n]);
        let r = &self.nodes[0];
        let w0 = u[0];
        let tau0 = -r.k_spring * (q[0] - r.q_free) - r.c_joint * w0;
        qd[0] = w0;
        let sum = forces(star, q, u, sin, cos, f, v, qd);
        f[0] = (tau0 - r.c_ground * w0) + sum;
        for jt in &self.torques {
            let tau = jt.excitation.torque(t);
            f[jt.joint] += tau;
            let p = self.nodes[jt.joint].parent;
            if p != GROUND_PARENT {
                f[p] -= tau;
            }
        }
        let (hs, zs) = eliminate(star, f, v);
        let h = star.diag0 - hs;
        // NaN must fail too, so test for "not greater" rather than "less or equal".
        if h.is_nan() || h <= PIVOT_TOL * star.scale {
            return Err(self.pivot_error(0, h));
        }
        let a0 = (f[0] - zs) * (1.0 / h);
        ud[0] = a0;
        for j in 1..n {
            let dj = star.d_inv[j];
            ud[j] = f[j] * dj - (v[j] * dj) * a0;
        }
        Ok(())
    }
}

/// The leaves' M_0j (into `v`), F_j (into `f`) and joint rates (into `qd`), and the sum of their
/// terms of F_0: `−τ_j + u_j² D_j` (the joint's spring and damper torque acts on both bodies).
#[allow(clippy::too_many_arguments)]
fn forces(
    star: &Star,
    q: &[f64],
    u: &[f64],
    sin: &[f64],
    cos: &[f64],
    f: &mut [f64],
    v: &mut [f64],
    qd: &mut [f64],
) -> f64 {
    #[cfg(target_arch = "x86_64")]
    if std::arch::is_x86_feature_detected!("avx2") {
        // SAFETY: the feature the function is compiled for was just detected.
        return unsafe { forces_avx2(star, q, u, sin, cos, f, v, qd) };
    }
    forces_body(star, q, u, sin, cos, f, v, qd)
}

/// [`forces`] compiled for AVX2 (the same operations: no contraction into fused multiply-adds).
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2")]
#[allow(clippy::too_many_arguments)]
unsafe fn forces_avx2(
    star: &Star,
    q: &[f64],
    u: &[f64],
    sin: &[f64],
    cos: &[f64],
    f: &mut [f64],
    v: &mut [f64],
    qd: &mut [f64],
) -> f64 {
    forces_body(star, q, u, sin, cos, f, v, qd)
}

#[inline(always)]
#[allow(clippy::too_many_arguments)]
fn forces_body(
    star: &Star,
    q: &[f64],
    u: &[f64],
    sin: &[f64],
    cos: &[f64],
    f: &mut [f64],
    v: &mut [f64],
    qd: &mut [f64],
) -> f64 {
    let m = sin.len();
    let u0 = u[0];
    let u02 = u0 * u0;
    let (q, u) = (&q[1..=m], &u[1..=m]);
    let (f, v, qd) = (&mut f[1..=m], &mut v[1..=m], &mut qd[1..=m]);
    let (al, be, ks, qf) = (&star.alpha[1..=m], &star.beta[1..=m], &star.k_spring[1..=m], &star.q_free[1..=m]);
    let (cj, cg) = (&star.c_joint[1..=m], &star.c_ground[1..=m]);
    let cos = &cos[..m];
    let mut acc = [0.0; 4];
    let mut j = 0;
    // Four leaves per round, one partial sum each (the same sums with or without vectors).
    while j + 4 <= m {
        for l in 0..4 {
            let i = j + l;
            let (s, c, w) = (sin[i], cos[i], u[i]);
            let d = al[i] * s + be[i] * c;
            v[i] = al[i] * c - be[i] * s;
            let rate = w - u0;
            qd[i] = rate;
            let tau = -ks[i] * (q[i] - qf[i]) - cj[i] * rate;
            f[i] = (tau - cg[i] * w) - u02 * d;
            acc[l] += w * w * d - tau;
        }
        j += 4;
    }
    for i in j..m {
        let (s, c, w) = (sin[i], cos[i], u[i]);
        let d = al[i] * s + be[i] * c;
        v[i] = al[i] * c - be[i] * s;
        let rate = w - u0;
        qd[i] = rate;
        let tau = -ks[i] * (q[i] - qf[i]) - cj[i] * rate;
        f[i] = (tau - cg[i] * w) - u02 * d;
        acc[i - j] += w * w * d - tau;
    }
    (acc[0] + acc[1]) + (acc[2] + acc[3])
}

/// The leaves' eliminations: `(Σ M_0j²/M_jj, Σ M_0j F_j/M_jj)`, in four partial sums.
fn eliminate(star: &Star, f: &[f64], v: &[f64]) -> (f64, f64) {
    let m = f.len() - 1;
    let (f, v, di) = (&f[1..], &v[1..], &star.d_inv[1..=m]);
    let (mut hs, mut zs) = ([0.0; 4], [0.0; 4]);
    let mut j = 0;
    while j + 4 <= m {
        for l in 0..4 {
            let i = j + l;
            let lk = v[i] * di[i];
            hs[l] += lk * v[i];
            zs[l] += lk * f[i];
        }
        j += 4;
    }
    for i in j..m {
        let lk = v[i] * di[i];
        hs[i - j] += lk * v[i];
        zs[i - j] += lk * f[i];
    }
    ((hs[0] + hs[1]) + (hs[2] + hs[3]), (zs[0] + zs[1]) + (zs[2] + zs[3]))
}
