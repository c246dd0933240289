//! The composite-body form of Kane's equations for joint rates (`u = q̇`), for every joint kind.
//!
//! With the motion columns of joint k in the basis, `ω_k` (angular) and `v_k` (velocity of its
//! point o_k), a body i below k has `ω_{i,k} = ω_k` and `v_{i,k} = v_k + ω_k ẑ × (r_i − o_k)`.
//! Summing Kane's terms over k's subtree, with its mass m_S and its first moment S and inertia J
//! about o_k, gives for k and an ancestor l (d = o_k − o_l):
//!
//! `M_kl = m_S v_k·v_l + ω_l v_k·(ẑ × (S + m_S d)) + ω_k (ẑ × S)·v_l + ω_k ω_l (J + S·d)`,
//!
//! and `F_k = v_k·R + ω_k N + τ_k` with R the subtree's resultant force and N its moment about o_k
//! (applied minus inertial at u̇ = 0) and τ_k the joint's own generalized force. For two revolute
//! joints (`ω = 1`, `v = 0`) this is `M_kl = J + S·d` and `F_k = N + τ_k`. The composite sums are
//! accumulated child → parent in one backward pass: O(n·depth) instead of O(Σ depth²).
//!
//! Everything about a joint comes from [`JointKind::motion`]: its transform, its columns and its
//! velocity-product terms; a new joint kind needs no change here.
//!
//! A path joint's rollers (docs/design.md, "Rollers") are one more node after the bodies, hanging
//! from the path's parent and moved by the path's coordinate k through
//! [`JointKind::roller_motion`]. Kane's sums have no term between two bodies, so the rollers'
//! node contributes to the same entries as the path joint (row k against k and its ancestors,
//! and F_k): it is reached first in the backward pass and sets them, the path node adds.

use super::{GROUND_PARENT, Kane, NO_COORD};
use crate::model::joint::{JointKind, JointMotion};
use crate::model::loads::ForceFrame;
use crate::model::math::{Vec2, cross2, perp, rotate_cs};

impl Kane {
    /// `Kane::evaluate` for joint rates (u = q̇; in the mapped form, u holds q̇ already), by
    /// composite bodies (see the module doc).
    #[inline(always)]
    pub(super) fn evaluate_rates<const N: usize>(&mut self, t: f64, q: &[f64], u: &[f64], forcing: bool) {
        let n = if N == 0 { self.n } else { N };
        let nb = if N == 0 { self.nb } else { N };
        let (world, g) = (self.world, self.gravity);
        let nodes = &self.nodes[..nb];
        let st = &mut self.state[..nb];
        let m = &mut self.m[..n * n];
        let f = &mut self.f[..n];
        // Forward pass, parents first: poses, rates, bias accelerations (q̈ = 0 at u̇ = 0), the
        // joints' columns, and each body's own contribution to its composite sums about o_j.
        for j in 0..nb {
            let nd = &nodes[j];
            let root = nd.parent == GROUND_PARENT;
            let has_coord = nd.coord != NO_COORD;
            let qj = if has_coord { q[nd.coord] } else { 0.0 };
            // A revolute root outside the world frame is the basis itself: its (cyclic) angle is
            // never turned into a sine and cosine.
            let mo = if let Some((centre, turn_rate)) = nd.satellite {
                // A path joint's rollers: moved by the path's coordinate relative to the path's
                // parent, a joint of their own for these sums (docs/design.md, "Rollers").
                nd.kind.roller_motion(nd.at, qj, centre, turn_rate)
            } else if root && !world && nd.kind == JointKind::Revolute {
                JointMotion {
                    cos: 1.0,
                    sin: 0.0,
                    origin: nd.at,
                    omega: 1.0,
                    velocity: Vec2::zeros(),
                    bias_alpha: 0.0,
                    bias_acc: Vec2::zeros(),
                }
            } else {
                nd.kind.motion(nd.at, qj)
            };
            // NOTE: the record is written field by field in place (not built and copied), so
            // fields that are not needed are not stored (measured, BENCHMARKS.md).
            let (done, rest) = st.split_at_mut(j);
            let b = &mut rest[0];
            let (pc, ps, w_p, alpha_p, acc_p) = if root {
                b.origin = mo.origin;
                b.d = Vec2::zeros();
                (1.0, 0.0, 0.0, 0.0, Vec2::zeros())
            } else {
                let p = &done[nd.parent];
                b.d = rotate_cs(p.c, p.s, mo.origin);
                b.origin = p.origin + b.d;
                (p.c, p.s, p.omega, p.alpha, p.acc_o)
            };
            b.c = pc * mo.cos - ps * mo.sin;
            b.s = ps * mo.cos + pc * mo.sin;
            b.col_w = mo.omega;
            b.col_v = rotate_cs(pc, ps, mo.velocity);
            let arm = rotate_cs(b.c, b.s, nd.com_local);
            b.first = nd.mass * arm;
            b.inertia = nd.j_own;
            if forcing {
                let qd = if has_coord { u[nd.coord] } else { 0.0 };
                b.qdot = qd;
                b.omega = w_p + mo.omega * qd;
                b.alpha = alpha_p + mo.bias_alpha * qd * qd;
                // o_j = o_p + d: the parent's acceleration, the transport terms of d (α_p ẑ×d −
                // ω_p² d), the Coriolis term of the relative velocity and the joint's own bias.
                let v_rel = b.col_v * qd;
                b.acc_o = acc_p + alpha_p * perp(b.d) - w_p * w_p * b.d
                    + 2.0 * w_p * perp(v_rel)
                    + rotate_cs(pc, ps, mo.bias_acc) * (qd * qd);
                let acc_c = b.acc_o + b.alpha * perp(arm) - b.omega * b.omega * arm;
                // Applied force at the centre of mass minus the inertia force m a⁰, and torque.
                let fi = nd.mass * (g - acc_c);
                b.force = fi;
                b.moment = cross2(arm, fi) - nd.i_com * b.alpha - nd.c_ground * b.omega;
                // NOTE: tested first so that the common body without point forces skips the
                // slice's range checks.
                if nd.forces.1 > nd.forces.0 {
                    for pfc in &self.point_forces[nd.forces.0..nd.forces.1] {
                        let force = match pfc.frame {
                            ForceFrame::World => pfc.force,
                            ForceFrame::Body => rotate_cs(b.c, b.s, pfc.force),
                        };
                        b.force += force;
                        b.moment += cross2(rotate_cs(b.c, b.s, pfc.at), force);
                    }
                }
                // The joint's own generalized force (spring, damper; the excitations are added below).
                b.tau = -nd.k_spring * (qj - nd.q_free) - nd.c_joint * qd;
            }
        }
        if forcing {
            for jt in &self.torques {
                st[jt.joint].tau += jt.excitation.torque(t);
            }
        }
        // Backward pass, children first: composite sums, rows of M and entries of F.
        for j in (0..nb).rev() {
            let (nd, b) = (&nodes[j], st[j]);
            if nd.coord != NO_COORD {
                let k = nd.coord;
                let mass = nd.subtree_mass;
                let revolute = nd.kind == JointKind::Revolute;
                // A path joint with rollers adds its terms to those its rollers' node wrote
                // (the same entries: the rollers hang from the path's parent); 0 otherwise.
                let (f0, m0) = if nd.adds { (f[k], m[k * n + k]) } else { (0.0, 0.0) };
                if forcing {
                    f[k] = f0 + (if revolute { b.moment } else { b.col_w * b.moment + b.col_v.dot(&b.force) } + b.tau);
                }
                m[k * n + k] = m0
                    + if revolute {
                        b.inertia
                    } else {
                        mass * b.col_v.norm_squared()
                            + 2.0 * b.col_w * b.col_v.dot(&perp(b.first))
                            + b.col_w * b.col_w * b.inertia
                    };
                let mut l = nd.parent;
                while l != GROUND_PARENT {
                    let a = &st[l];
                    let lc = nodes[l].coord;
                    if lc != NO_COORD {
                        let d = b.origin - a.origin;
                        let v = if revolute && nodes[l].kind == JointKind::Revolute {
                            b.inertia + b.first.dot(&d)
                        } else {
                            mass * b.col_v.dot(&a.col_v)
                                + a.col_w * b.col_v.dot(&perp(b.first + mass * d))
                                + b.col_w * perp(b.first).dot(&a.col_v)
                                + b.col_w * a.col_w * (b.inertia + b.first.dot(&d))
                        };
                        let v = if nd.adds { m[k * n + lc] + v } else { v };
                        m[k * n + lc] = v;
                        m[lc * n + k] = v;
                    }
                    l = nodes[l].parent;
                }
            }
            let p = nd.parent;
            if p != GROUND_PARENT {
                let d = b.d;
                let bp = &mut st[p];
                bp.force += b.force;
                bp.moment += b.moment + cross2(d, b.force);
                let mass = nd.subtree_mass;
                bp.inertia += b.inertia + 2.0 * d.dot(&b.first) + mass * d.norm_squared();
                bp.first += b.first + mass * d;
            }
        }
    }
}
