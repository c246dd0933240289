//! The right-hand side of bodies turning on one axis, with absorbers hung on some of them, in one
//! pass: absolute angular velocities, where the only inertial couplings are between a body and
//! the leaves pivoted off its axis (`Model::axial_rhs`). An elastic crankshaft (disks joined by
//! torsional springs, each pivoted on its neighbour at the axis) carrying pendulums is such a
//! mechanism, as is any lumped torsional chain or tree.
//!
//! Method: the pair form of [`super::absolute`]. A pair (k, j), k an ancestor of j, has
//! `α = at_c·S'_j`, `β = at_c × S'_j` with at_c the joint point of k's child c towards j: a body
//! pivoted at its parent's joint point (at_c = 0) couples with none of its ancestors, so a chain
//! of disks on one axis has a constant diagonal mass matrix in absolute speeds. What remains are
//! the pairs (h, l) of a *hub* h and a *leaf* l pivoted on it off the axis (a pendulum on its
//! rotor), with `M_hl = α cos q_l − β sin q_l` and the pair's centripetal forces
//! `F_h += u_l² D`, `F_l −= u_h² D`, `D = α sin q_l + β cos q_l`. When every non-zero pair is of
//! that kind (the leaf's parent its hub, no hub a leaf, no leaf a hub), M is a diagonal plus a
//! forest of stars, and its leaves-first factorisation (as [`super::tree`], written out for
//! this pattern) is exact and fill-free: eliminating leaf l subtracts `M_hl²/M_ll` from its
//! hub's pivot and `M_hl F_l/M_ll` from the hub's right-hand side, then `u̇_h` follows and
//! `u̇_l = (F_l − M_hl u̇_h)/M_ll`. The joints' springs and dampers act on
//! `q̇_j = u_j − u_parent`, on the body and, reversed, on its parent, as in the pair form.
//!
//! NOTE: the articulated-body route ([`super::articulated`]) serves these mechanisms too, at
//! a constant per body that is an order of magnitude larger (3-vector inertias and shifts, a
//! sine and cosine per joint); on the 16-disk crankshaft with a pendulum this pass is what the
//! explicit sweep's cost is made of (BENCHMARKS.md, "Stiff shafts").

use super::{GROUND_PARENT, Model, NONE, PIVOT_TOL, Workspace};
use crate::error::EngineError;
use crate::model::sincos::sin_cos_many;

/// One body's constants, packed so the first pass reads one record per body.
#[derive(Debug, Clone, Copy)]
struct Disk {
    /// The parent's speed (`NONE` for a root).
    parent: usize,
    k_spring: f64,
    q_free: f64,
    c_joint: f64,
    c_ground: f64,
    /// 1/M_jj.
    d_inv: f64,
}

/// A leaf pivoted off its hub's axis: its speed, its hub's speed and slot in the hubs' list,
/// the pair's (α, β), and 1/M_ll.
#[derive(Debug, Clone, Copy)]
struct Leaf {
    speed: usize,
    hub: usize,
    slot: usize,
    alpha: f64,
    beta: f64,
    d_inv: f64,
}

/// The constants of the one-pass right-hand side of bodies on one axis (see the module doc).
#[derive(Debug, Clone)]
pub(super) struct Axial {
    disks: Vec<Disk>,
    leaves: Vec<Leaf>,
    /// The hubs' speeds and constant M_hh.
    hubs: Vec<(usize, f64)>,
    /// The disks' constants by quantity (k, q_free, c_joint, c_ground), when the bodies form one
    /// chain (speed 0 the root, every other body's parent the speed before it: a crankshaft with
    /// its flywheel and a pendulum on it), for the branch-free pass of [`Model::rhs_axial`].
    chain: Option<[Vec<f64>; 4]>,
    /// The pivots' scale (the largest diagonal entry).
    scale: f64,
}

/// Below this many leaves their angles' sines and cosines are taken one by one (std's), above
/// four per vector ([`sin_cos_many`], whose set-up costs more than one std call for a single
/// angle: measured on the crankshaft's one pendulum).
const SCALAR_LEAVES: usize = 4;

impl Model {
    /// The constants when [`Model::rhs_axial`] applies: the pair form without gravity, point
    /// forces, couplings, rollers or fixed joints, more than six speeds, every non-zero pair a
    /// leaf on its parent, no hub a leaf and no leaf a hub, and the constant pivots positive.
    pub(super) fn axial_rhs(&self) -> Option<Axial> {
        let n = self.n;
        let gravity = self.world && self.gravity != crate::model::math::Vec2::zeros();
        if n <= super::SMALL
            || self.nb != n
            || self.form != super::Form::Pairs
            || gravity
            || !self.point_forces.is_empty()
            || !self.couplings.is_empty()
            || !self.rollers.is_empty()
        {
            return None;
        }
        let nodes = &self.nodes[..n];
        // The pairs in the order `evaluate_absolute` walks them: j ascending, k from j's parent up.
        let (mut pairs, mut hub, mut leaf) = (Vec::new(), vec![false; n], vec![false; n]);
        let mut pair = 0;
        for (j, nd) in nodes.iter().enumerate() {
            let mut k = nd.parent;
            while k != GROUND_PARENT {
                let (alpha, beta) = *self.pairs.get(pair)?;
                pair += 1;
                if alpha == 0.0 && beta == 0.0 {
                    // No inertial coupling: nothing to carry.
                } else if k == nd.parent && !leaf[j] {
                    leaf[j] = true;
                    hub[k] = true;
                    pairs.push((j, alpha, beta));
                } else {
                    return None;
                }
                k = nodes[k].parent;
            }
        }
        if pair != self.pairs.len() || (0..n).any(|j| hub[j] && leaf[j]) {
            return None;
        }
        let scale = nodes.iter().fold(0.0f64, |s, nd| s.max(nd.diag_abs.abs()));
        if nodes.iter().any(|nd| nd.diag_abs.is_nan() || nd.diag_abs <= PIVOT_TOL * scale) {
            return None;
        }
        let hubs: Vec<(usize, f64)> = (0..n).filter(|&j| hub[j]).map(|j| (j, nodes[j].diag_abs)).collect();
        let leaves = pairs
            .into_iter()
            .map(|(l, alpha, beta)| {
                let h = nodes[l].parent;
                let slot = hubs.iter().position(|&(k, _)| k == h).expect("a leaf's parent is a hub");
                Leaf { speed: l, hub: h, slot, alpha, beta, d_inv: 1.0 / nodes[l].diag_abs }
            })
            .collect();
        let disks = nodes
            .iter()
            .map(|nd| Disk {
                parent: if nd.parent == GROUND_PARENT { NONE } else { nd.parent },
                k_spring: nd.k_spring,
                q_free: nd.q_free,
                c_joint: nd.c_joint,
                c_ground: nd.c_ground,
                d_inv: 1.0 / nd.diag_abs,
            })
            .collect();
        let chain = (nodes[0].parent == GROUND_PARENT && (1..n).all(|j| nodes[j].parent == j - 1)).then(|| {
            [
                nodes.iter().map(|nd| nd.k_spring).collect(),
                nodes.iter().map(|nd| nd.q_free).collect(),
                nodes.iter().map(|nd| nd.c_joint).collect(),
                nodes.iter().map(|nd| nd.c_ground).collect(),
            ]
        });
        Some(Axial { disks, leaves, hubs, scale, chain })
    }

    /// `Kane::rhs` for bodies on one axis with leaves ([`Model::axial_rhs`]; see the module doc).
    pub(super) fn rhs_axial(
        &self,
        ax: &Axial,
        ws: &mut Workspace,
        t: f64,
        x: &[f64],
        xdot: &mut [f64],
    ) -> Result<(), EngineError> {
        let n = self.n;
        let (q, u) = x.split_at(n);
        let (qd, ud) = xdot.split_at_mut(n);
        let (f, tau) = (&mut ws.f[..n], &mut ws.row[..n]);
        // Joint springs and dampers on q̇_j = u_j − u_parent, the ground dampers; then each joint's
        // torque, reversed, on its parent. NOTE: two passes, so that no body waits for the store
        // of its parent's F (on a chain each body's subtraction from its parent followed that
        // parent's own store: one serial chain through memory).
        if let Some([k, q0, c, cg]) = &ax.chain {
            // NOTE: the same operations as the general passes below, over slices without a
            // branch or a gather, four bodies per AVX2 vector where detected (same bits); each
            // body's F takes its child's joint torque computed anew rather than read back from
            // memory (the reload of a vector just stored, one body along, stalled the store
            // forwarding: a fifth of the pass).
            let consts = [&k[..], &q0[..], &c[..], &cg[..]];
            let (rate0, t0) = (u[0], -k[0] * (q[0] - q0[0]) - c[0] * u[0]);
            qd[0] = rate0;
            f[0] = (t0 - cg[0] * u[0]) - joint_torque(consts, q, u, 1).1;
            let mut from = 1;
            #[cfg(target_arch = "x86_64")]
            if std::arch::is_x86_feature_detected!("avx2") {
                // SAFETY: the feature the function is compiled for was just detected.
                from = unsafe { chain_avx2(consts, q, u, qd, f) };
            }
            chain_scalar(consts, q, u, qd, f, from);
        } else {
            for (j, b) in ax.disks.iter().enumerate() {
                let w = u[j];
                let rate = if b.parent == NONE { w } else { w - u[b.parent] };
                qd[j] = rate;
                let t = -b.k_spring * (q[j] - b.q_free) - b.c_joint * rate;
                tau[j] = t;
                f[j] = t - b.c_ground * w;
            }
            for (b, &t) in ax.disks.iter().zip(tau.iter()) {
                if b.parent != NONE {
                    f[b.parent] -= t;
                }
            }
        }
        for jt in &self.torques {
            let tau = jt.excitation.torque(t);
            f[jt.joint] += tau;
            let p = ax.disks[jt.joint].parent;
            if p != NONE {
                f[p] -= tau;
            }
        }
        let nl = ax.leaves.len();
        let (sin, cos) = (&mut ws.sin[..nl], &mut ws.cos[..nl]);
        if nl < SCALAR_LEAVES {
            for ((s, c), lf) in sin.iter_mut().zip(cos.iter_mut()).zip(&ax.leaves) {
                (*s, *c) = q[lf.speed].sin_cos();
            }
        } else {
            let angles = &mut ws.qdot[..nl];
            for (a, lf) in angles.iter_mut().zip(&ax.leaves) {
                *a = q[lf.speed];
            }
            sin_cos_many(angles, sin, cos);
        }
        // Each pair's inertial coupling and centripetal forces, then the leaf's elimination into
        // its hub's pivot (`piv`) and right-hand side (f_l is complete once its pair is added).
        let (v, piv) = (&mut ws.l[..nl], &mut ws.d_inv[..ax.hubs.len()]);
        for (p, &(_, d)) in piv.iter_mut().zip(&ax.hubs) {
            *p = d;
        }
        for (i, lf) in ax.leaves.iter().enumerate() {
            let (s, c) = (sin[i], cos[i]);
            let (l, h) = (lf.speed, lf.hub);
            let m_hl = lf.alpha * c - lf.beta * s;
            let d = lf.alpha * s + lf.beta * c;
            v[i] = m_hl;
            let fl = f[l] - u[h] * u[h] * d;
            f[l] = fl;
            let lk = m_hl * lf.d_inv;
            f[h] += u[l] * u[l] * d - lk * fl;
            piv[lf.slot] -= lk * m_hl;
        }
        for ((a, fj), b) in ud.iter_mut().zip(f.iter()).zip(&ax.disks) {
            *a = fj * b.d_inv;
        }
        for (&(h, _), &p) in ax.hubs.iter().zip(piv.iter()) {
            // NaN must fail too, so test for "not greater" rather than "less or equal".
            if p.is_nan() || p <= PIVOT_TOL * ax.scale {
                return Err(self.pivot_error(h, p));
            }
            ud[h] = f[h] / p;
        }
        for (lf, &m_hl) in ax.leaves.iter().zip(v.iter()) {
            ud[lf.speed] = (f[lf.speed] - m_hl * ud[lf.hub]) * lf.d_inv;
        }
        Ok(())
    }
}

/// Body j's joint rate and joint torque (spring and damper) on a chain (`j ≥ 1`, its parent
/// j − 1).
#[inline(always)]
fn joint_torque([k, q0, c, _]: [&[f64]; 4], q: &[f64], u: &[f64], j: usize) -> (f64, f64) {
    let rate = u[j] - u[j - 1];
    (rate, -k[j] * (q[j] - q0[j]) - c[j] * rate)
}

/// The chain's bodies from `from` on (each after its predecessor): joint rates into `qd`, and
/// into `f` each body's F, its own torque less its ground damper's less its child's torque.
#[inline(always)]
fn chain_scalar(consts: [&[f64]; 4], q: &[f64], u: &[f64], qd: &mut [f64], f: &mut [f64], from: usize) {
    let n = qd.len();
    let cg = consts[3];
    for j in from..n {
        let (rate, t) = joint_torque(consts, q, u, j);
        qd[j] = rate;
        let child = if j + 1 < n { joint_torque(consts, q, u, j + 1).1 } else { 0.0 };
        f[j] = (t - cg[j] * u[j]) - child;
    }
}

/// [`chain_scalar`] from body 1 in AVX2 vectors, four bodies a round while their four children
/// exist, with the scalar loop's operations (no fused multiply-adds), so the same bits; returns
/// the first body not done.
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2")]
unsafe fn chain_avx2([k, q0, c, cg]: [&[f64]; 4], q: &[f64], u: &[f64], qd: &mut [f64], f: &mut [f64]) -> usize {
    use std::arch::x86_64::*;
    let n = qd.len();
    // Rounds of bodies j..j + 3 with children j + 1..j + 4 < n.
    let rounds = n.saturating_sub(2) / 4;
    assert!([k, q0, c, cg, q, u].iter().all(|a| a.len() >= n) && f.len() >= n);
    // SAFETY: every access is at 1 + 4r + 4 ≤ n − 1 (or one before, for the parents' speeds),
    // checked above.
    unsafe {
        let ld = |a: &[f64], i: usize| _mm256_loadu_pd(a.as_ptr().add(i));
        let neg = _mm256_set1_pd(-0.0);
        let torque = |j: usize| {
            let rate = _mm256_sub_pd(ld(u, j), ld(u, j - 1));
            let t = _mm256_sub_pd(
                _mm256_mul_pd(_mm256_xor_pd(ld(k, j), neg), _mm256_sub_pd(ld(q, j), ld(q0, j))),
                _mm256_mul_pd(ld(c, j), rate),
            );
            (rate, t)
        };
        for r in 0..rounds {
            let j = 1 + 4 * r;
            let (rate, t) = torque(j);
            let (_, child) = torque(j + 1);
            _mm256_storeu_pd(qd.as_mut_ptr().add(j), rate);
            let own = _mm256_sub_pd(t, _mm256_mul_pd(ld(cg, j), ld(u, j)));
            _mm256_storeu_pd(f.as_mut_ptr().add(j), _mm256_sub_pd(own, child));
        }
    }
    1 + 4 * rounds
}

#[cfg(test)]
mod tests {
    /// The chain's AVX2 pass gives the scalar loop's bits, for every remainder of its rounds.
    #[cfg(target_arch = "x86_64")]
    #[test]
    fn the_chain_vector_pass_equals_the_scalar_loop() {
        use crate::kane::vector_tests::{avx2, series};
        if !avx2() {
            return;
        }
        for n in 2..=14 {
            let per = |a: f64| series(n, a);
            let (k, q0, c, cg, q, u) = (per(2.1), per(0.2), per(0.9), per(0.4), per(1.1), per(5.7));
            let consts = [&k[..], &q0[..], &c[..], &cg[..]];
            let mut a = (vec![0.0; n], vec![0.0; n]);
            let mut b = a.clone();
            super::chain_scalar(consts, &q, &u, &mut a.0, &mut a.1, 1);
            // SAFETY: AVX2 was detected above.
            let from = unsafe { super::chain_avx2(consts, &q, &u, &mut b.0, &mut b.1) };
            super::chain_scalar(consts, &q, &u, &mut b.0, &mut b.1, from);
            let bits = |v: &[f64]| v.iter().map(|x| x.to_bits()).collect::<Vec<_>>();
            assert_eq!((bits(&a.0), bits(&a.1)), (bits(&b.0), bits(&b.1)), "{n} bodies");
        }
    }
}
