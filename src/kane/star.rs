//! The right-hand side of a rotor carrying many pendulums in one pass per stage: absolute
//! angular velocities, speed 0 a root spinning on the ground, every other speed a revolute leaf
//! pivoted on it (`Model::star_rhs`).
//!
//! Method: the pair form of [`super::absolute`] (`M_0j = α_j cos φ_j − β_j sin φ_j`,
//! `D_j = α_j sin φ_j + β_j cos φ_j`, constant diagonal) with the leaves-first factorisation of
//! [`super::tree`] written out for this tree: eliminating leaf j subtracts `M_0j²/M_jj` from the
//! root's pivot and `M_0j F_j/M_jj` from its right-hand side, and then
//! `u̇_j = (F_j − M_0j u̇_0)/M_jj`. The leaves' constants are packed per quantity at build, so
//! each pass runs over arrays, four leaves per AVX2 vector where that is detected at run time
//! (the scalar loop's operations otherwise, with the same bits); the root's sums are taken in
//! four interleaved partial sums, which changes their rounding against the general path (u̇
//! within 1e-12 of its largest entry of the dense LDLᵀ's in `tests/it/random_trees.rs`) but not
//! between machines with and without AVX2.

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
        if self.nodes[1..n].iter().any(|nd| nd.diag_abs.is_nan() || nd.diag_abs <= PIVOT_TOL * scale) {
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

/// [`forces_body`] in AVX2 vectors: four leaves per round, each lane one of the partial sums,
/// and the same operations as the scalar loop (no fused multiply-adds), so the same bits.
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
    use std::arch::x86_64::*;
    let m = sin.len();
    let rounds = m / 4;
    assert!(
        cos.len() >= m
            && q.len() > m
            && u.len() > m
            && f.len() > m
            && v.len() > m
            && qd.len() > m
            && [&star.alpha, &star.beta, &star.k_spring, &star.q_free, &star.c_joint, &star.c_ground]
                .iter()
                .all(|a| a.len() > m)
    );
    let u0 = u[0];
    let u02 = u0 * u0;
    let mut acc = [0.0; 4];
    // SAFETY: every access is at 1 + 4r + 3 ≤ m (leaf arrays, m + 1 long) or 4r + 3 < m (sin,
    // cos), checked above.
    unsafe {
        let ld = |a: &[f64], i: usize| _mm256_loadu_pd(a.as_ptr().add(i));
        let (vu0, vu02) = (_mm256_set1_pd(u0), _mm256_set1_pd(u02));
        let mut vacc = _mm256_setzero_pd();
        for r in 0..rounds {
            let (i, k) = (4 * r, 4 * r + 1);
            let (s, c, w) = (ld(sin, i), ld(cos, i), ld(u, k));
            let (al, be) = (ld(&star.alpha, k), ld(&star.beta, k));
            let d = _mm256_add_pd(_mm256_mul_pd(al, s), _mm256_mul_pd(be, c));
            _mm256_storeu_pd(v.as_mut_ptr().add(k), _mm256_sub_pd(_mm256_mul_pd(al, c), _mm256_mul_pd(be, s)));
            let rate = _mm256_sub_pd(w, vu0);
            _mm256_storeu_pd(qd.as_mut_ptr().add(k), rate);
            let neg_ks = _mm256_xor_pd(ld(&star.k_spring, k), _mm256_set1_pd(-0.0));
            let tau = _mm256_sub_pd(
                _mm256_mul_pd(neg_ks, _mm256_sub_pd(ld(q, k), ld(&star.q_free, k))),
                _mm256_mul_pd(ld(&star.c_joint, k), rate),
            );
            let fk = _mm256_sub_pd(_mm256_sub_pd(tau, _mm256_mul_pd(ld(&star.c_ground, k), w)), _mm256_mul_pd(vu02, d));
            _mm256_storeu_pd(f.as_mut_ptr().add(k), fk);
            vacc = _mm256_add_pd(vacc, _mm256_sub_pd(_mm256_mul_pd(_mm256_mul_pd(w, w), d), tau));
        }
        _mm256_storeu_pd(acc.as_mut_ptr(), vacc);
    }
    leaves(star, q, u, sin, cos, f, v, qd, 4 * rounds, &mut acc);
    (acc[0] + acc[1]) + (acc[2] + acc[3])
}

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
    let mut acc = [0.0; 4];
    leaves(star, q, u, sin, cos, f, v, qd, 0, &mut acc);
    (acc[0] + acc[1]) + (acc[2] + acc[3])
}

/// The scalar loop of [`forces`] over the leaves from `from` (a multiple of 4) on: leaf
/// `from + i` adds its term of F_0 to the partial sum `acc[i % 4]`.
#[allow(clippy::too_many_arguments)]
fn leaves(
    star: &Star,
    q: &[f64],
    u: &[f64],
    sin: &[f64],
    cos: &[f64],
    f: &mut [f64],
    v: &mut [f64],
    qd: &mut [f64],
    from: usize,
    acc: &mut [f64; 4],
) {
    let u0 = u[0];
    let u02 = u0 * u0;
    for i in from..sin.len() {
        let k = i + 1;
        let (s, c, w) = (sin[i], cos[i], u[k]);
        let (al, be) = (star.alpha[k], star.beta[k]);
        let d = al * s + be * c;
        v[k] = al * c - be * s;
        let rate = w - u0;
        qd[k] = rate;
        let tau = -star.k_spring[k] * (q[k] - star.q_free[k]) - star.c_joint[k] * rate;
        f[k] = (tau - star.c_ground[k] * w) - u02 * d;
        acc[i % 4] += w * w * d - tau;
    }
}

/// The leaves' eliminations: `(Σ M_0j²/M_jj, Σ M_0j F_j/M_jj)`, in four partial sums (leaf j
/// in sum (j − 1) mod 4).
fn eliminate(star: &Star, f: &[f64], v: &[f64]) -> (f64, f64) {
    let (mut hs, mut zs) = ([0.0; 4], [0.0; 4]);
    let mut from = 0;
    #[cfg(target_arch = "x86_64")]
    if std::arch::is_x86_feature_detected!("avx2") {
        // SAFETY: the feature the function is compiled for was just detected.
        from = unsafe { eliminate_avx2(star, f, v, &mut hs, &mut zs) };
    }
    let m = f.len() - 1;
    for i in from..m {
        let k = i + 1;
        let lk = v[k] * star.d_inv[k];
        hs[i % 4] += lk * v[k];
        zs[i % 4] += lk * f[k];
    }
    ((hs[0] + hs[1]) + (hs[2] + hs[3]), (zs[0] + zs[1]) + (zs[2] + zs[3]))
}

/// The whole rounds of four leaves of [`eliminate`] in AVX2 vectors (the same operations, so the
/// same bits); returns the number of leaves done.
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2")]
unsafe fn eliminate_avx2(star: &Star, f: &[f64], v: &[f64], hs: &mut [f64; 4], zs: &mut [f64; 4]) -> usize {
    use std::arch::x86_64::*;
    let m = f.len() - 1;
    assert!(v.len() > m && star.d_inv.len() > m);
    let rounds = m / 4;
    // SAFETY: every load is at 1 + 4r + 3 ≤ m, checked above.
    unsafe {
        let ld = |a: &[f64], i: usize| _mm256_loadu_pd(a.as_ptr().add(i));
        let (mut vh, mut vz) = (_mm256_setzero_pd(), _mm256_setzero_pd());
        for r in 0..rounds {
            let k = 4 * r + 1;
            let vk = ld(v, k);
            let lk = _mm256_mul_pd(vk, ld(&star.d_inv, k));
            vh = _mm256_add_pd(vh, _mm256_mul_pd(lk, vk));
            vz = _mm256_add_pd(vz, _mm256_mul_pd(lk, ld(f, k)));
        }
        _mm256_storeu_pd(hs.as_mut_ptr(), vh);
        _mm256_storeu_pd(zs.as_mut_ptr(), vz);
    }
    4 * rounds
}

#[cfg(test)]
mod tests {
    use super::{Star, eliminate, forces_body};

    /// The AVX2 passes give the scalar loops' bits, for every remainder of the four-leaf rounds.
    #[cfg(target_arch = "x86_64")]
    #[test]
    fn vector_passes_equal_the_scalar_loops() {
        use crate::kane::vector_tests::{avx2, series};
        if !avx2() {
            return;
        }
        for m in 4..=13 {
            let per = |a: f64| series(m + 1, a);
            let star = Star {
                alpha: per(0.7),
                beta: per(1.3),
                k_spring: per(2.1),
                q_free: per(0.2),
                c_joint: per(0.9),
                c_ground: per(0.4),
                d_inv: per(3.3),
                diag0: 1.0,
                scale: 1.0,
            };
            let (q, u, sin, cos) = (per(1.1), per(5.7), per(0.31)[1..].to_vec(), per(0.47)[1..].to_vec());
            let (mut f1, mut v1, mut qd1) = (vec![0.0; m + 1], vec![0.0; m + 1], vec![0.0; m + 1]);
            let (mut f2, mut v2, mut qd2) = (f1.clone(), v1.clone(), qd1.clone());
            let s1 = forces_body(&star, &q, &u, &sin, &cos, &mut f1, &mut v1, &mut qd1);
            // SAFETY: AVX2 was detected above.
            let s2 = unsafe { super::forces_avx2(&star, &q, &u, &sin, &cos, &mut f2, &mut v2, &mut qd2) };
            assert_eq!(s1.to_bits(), s2.to_bits(), "{m} leaves");
            assert_eq!((f1.clone(), v1.clone(), qd1), (f2, v2, qd2), "{m} leaves");
            let mut hs = [0.0; 4];
            let mut zs = [0.0; 4];
            for i in 0..m {
                let lk = v1[i + 1] * star.d_inv[i + 1];
                hs[i % 4] += lk * v1[i + 1];
                zs[i % 4] += lk * f1[i + 1];
            }
            let scalar = ((hs[0] + hs[1]) + (hs[2] + hs[3]), (zs[0] + zs[1]) + (zs[2] + zs[3]));
            let (h, z) = eliminate(&star, &f1, &v1);
            assert_eq!((h.to_bits(), z.to_bits()), (scalar.0.to_bits(), scalar.1.to_bits()), "{m} leaves");
        }
    }
}
