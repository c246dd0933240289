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
//! Everything about a joint comes from the joint kind's `motion` ([`crate::model::joint`]): its transform, its columns and its
//! velocity-product terms; a new joint kind needs no change here.
//!
//! A path joint's rollers (docs/design/paths.md, "Rollers") are one rigid body each, hanging from the
//! path's parent and moved by the path's coordinate through the kind's `roller_motion`. Kane's
//! sums have no term between two bodies, so their terms are simply added after the composite
//! pass (`Model::add_rollers`), body by body as the textbook writes them: for every pair of
//! columns acting on them (their own, the path's coordinate, and each ancestor's),
//! `M_ab += m v_a·v_b + I ω_a ω_b` and `F_a += (f − m a⁰)·v_a + (T − I α⁰) ω_a`. The bodies' passes
//! stay the code they were.

use super::{BodyState, GROUND_PARENT, Model, NO_COORD, Satellite, Workspace};
use crate::model::joint::JointMotion;
use crate::model::loads::ForceFrame;
use crate::model::math::{Vec2, cross2, perp, rotate_cs};

impl Model {
    /// `Model::evaluate` for joint rates (u = q̇; in the mapped form, u holds q̇ already), by
    /// composite bodies (see the module doc).
    #[inline(always)]
    pub(super) fn evaluate_rates<const N: usize>(
        &self,
        ws: &mut Workspace,
        t: f64,
        q: &[f64],
        u: &[f64],
        forcing: bool,
    ) {
        let n = if N == 0 { self.n } else { N };
        let nb = if N == 0 { self.nb } else { N };
        self.forward_rates::<N>(ws, t, q, u, forcing);
        let nodes = &self.nodes[..nb];
        let st = &mut ws.state[..nb];
        let m = &mut ws.m[..n * n];
        let f = &mut ws.f[..n];
        // Backward pass, children first: composite sums, rows of M and entries of F.
        for j in (0..nb).rev() {
            let (nd, b) = (&nodes[j], st[j]);
            if nd.coord != NO_COORD {
                let k = nd.coord;
                let mass = nd.subtree_mass;
                let revolute = nd.kind.rotates();
                if forcing {
                    f[k] = if revolute { b.moment } else { b.col_w * b.moment + b.col_v.dot(&b.force) } + b.tau;
                }
                m[k * n + k] = if revolute {
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
                        let v = if revolute && nodes[l].kind.rotates() {
                            b.inertia + b.first.dot(&d)
                        } else {
                            mass * b.col_v.dot(&a.col_v)
                                + a.col_w * b.col_v.dot(&perp(b.first + mass * d))
                                + b.col_w * perp(b.first).dot(&a.col_v)
                                + b.col_w * a.col_w * (b.inertia + b.first.dot(&d))
                        };
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

impl Model {
    /// The forward pass of [`Model::evaluate_rates`], parents first, shared with the
    /// articulated-body route ([`super::articulated`]): every body's pose, rates, bias
    /// accelerations (q̈ = 0 at u̇ = 0), its joint's columns, its own first moment and inertia about
    /// its joint point, and (when `forcing`) its applied-minus-inertial force and moment about
    /// that point and its joint's generalized force with the excitations.
    #[inline(always)]
    pub(super) fn forward_rates<const N: usize>(
        &self,
        ws: &mut Workspace,
        t: f64,
        q: &[f64],
        u: &[f64],
        forcing: bool,
    ) {
        let nb = if N == 0 { self.nb } else { N };
        let (world, g) = (self.world, self.gravity);
        let nodes = &self.nodes[..nb];
        let st = &mut ws.state[..nb];
        // Forward pass, parents first: poses, rates, bias accelerations (q̈ = 0 at u̇ = 0), the
        // joints' columns, and each body's own contribution to its composite sums about o_j.
        for j in 0..nb {
            let nd = &nodes[j];
            let root = nd.parent == GROUND_PARENT;
            let has_coord = nd.coord != NO_COORD;
            let qj = if has_coord { q[nd.coord] } else { 0.0 };
            // A revolute root outside the world frame is the basis itself: its (cyclic) angle is
            // never turned into a sine and cosine.
            let mo = if root && !world && nd.kind.rotates() {
                JointMotion { omega: 1.0, ..JointMotion::still(nd.at) }
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
    }
}

impl Model {
    /// Adds the rollers' terms to M and F in joint rates, after [`Model::evaluate_rates`] has
    /// left every body's pose, rates, columns and bias accelerations in its record (see the
    /// module doc). The rollers' centroid r and the columns acting on it: their own
    /// (`ω = dψ/ds`, `v = ½ t` turned into the basis) for the path's coordinate, and for each
    /// ancestor joint A above the path's parent `ω_A` and `v_A + ω_A ẑ × (r − o_A)`.
    ///
    /// NOTE: out of line and after the composite pass, so that a tree without rollers runs the
    /// bodies' loops alone, compiled as they were.
    #[inline(never)]
    pub(super) fn add_rollers(&self, ws: &mut Workspace, q: &[f64], u: &[f64], forcing: bool) {
        let n = self.n;
        let (rollers, nodes) = (&self.rollers, &self.nodes);
        let Workspace { state, m, f, walk, .. } = ws;
        let (m, f) = (&mut m[..n * n], &mut f[..n]);
        for sat in rollers.iter() {
            let k = sat.coord;
            let RollerTerms { r, col_w, col_v, force, moment } = self.roller_terms(sat, state, q, u, forcing);
            // The ancestors with a coordinate, nearest first.
            walk.clear();
            let mut l = sat.parent;
            while l != GROUND_PARENT {
                if nodes[l].coord != NO_COORD {
                    walk.push(l);
                }
                l = nodes[l].parent;
            }
            let column = |i: usize| -> (usize, f64, Vec2) {
                if i == 0 {
                    (k, col_w, col_v)
                } else {
                    let a = &state[walk[i - 1]];
                    (nodes[walk[i - 1]].coord, a.col_w, a.col_v + a.col_w * perp(r - a.origin))
                }
            };
            for i in 0..=walk.len() {
                let (ka, wa, va) = column(i);
                if forcing {
                    f[ka] += force.dot(&va) + moment * wa;
                }
                for jj in i..=walk.len() {
                    let (kb, wb, vb) = column(jj);
                    let v = sat.mass * va.dot(&vb) + sat.i_com * wa * wb;
                    m[ka * n + kb] += v;
                    if kb != ka {
                        m[kb * n + ka] += v;
                    }
                }
            }
        }
    }
}

/// One path joint's rollers at the present state (after the forward pass), for
/// [`Model::add_rollers`] and the articulated-body route.
#[derive(Debug, Clone, Copy)]
pub(super) struct RollerTerms {
    /// Their centroid (the basis' coordinates), m.
    pub(super) r: Vec2,
    /// Their columns for the path's coordinate: angular velocity and centroid velocity per unit rate.
    pub(super) col_w: f64,
    pub(super) col_v: Vec2,
    /// Applied minus inertial force at u̇ = 0 (N) and moment about the centroid (N·m); zero
    /// unless `forcing`.
    pub(super) force: Vec2,
    pub(super) moment: f64,
}

impl Model {
    /// The rollers `sat`'s centroid, columns and bias force from their parent's record in
    /// `state` (see [`Model::add_rollers`]); `u` holds the joint rates.
    #[inline(always)]
    pub(super) fn roller_terms(
        &self,
        sat: &Satellite,
        state: &[BodyState],
        q: &[f64],
        u: &[f64],
        forcing: bool,
    ) -> RollerTerms {
        let k = sat.coord;
        let mo = sat.kind.roller_motion(sat.at, q[k], sat.centre, sat.turn_rate);
        let (pc, ps, w_p, alpha_p, acc_p, o_p) = if sat.parent == GROUND_PARENT {
            (1.0, 0.0, 0.0, 0.0, Vec2::zeros(), Vec2::zeros())
        } else {
            let p = &state[sat.parent];
            (p.c, p.s, p.omega, p.alpha, p.acc_o, p.origin)
        };
        let d = rotate_cs(pc, ps, mo.origin);
        let (col_w, col_v) = (mo.omega, rotate_cs(pc, ps, mo.velocity));
        // Applied minus inertial at u̇ = 0 (gravity, the transport, Coriolis and bias terms
        // as for a body's joint point; the centre of mass is the node's origin).
        let (force, moment) = if forcing {
            let qd = u[k];
            let alpha = alpha_p + mo.bias_alpha * qd * qd;
            let acc = acc_p + alpha_p * perp(d) - w_p * w_p * d
                + 2.0 * w_p * perp(col_v * qd)
                + rotate_cs(pc, ps, mo.bias_acc) * (qd * qd);
            (sat.mass * (self.gravity - acc), -sat.i_com * alpha)
        } else {
            (Vec2::zeros(), 0.0)
        };
        RollerTerms { r: o_p + d, col_w, col_v, force, moment }
    }
}
