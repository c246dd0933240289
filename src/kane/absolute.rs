//! The pair form of Kane's equations for absolute angular velocities (`u_k = ω_k`, the paper's
//! choice `u1 = θ̇`, `u2 = θ̇ + φ̇`, eqs. 8 and 26), with its exact Jacobian.
//!
//! With absolute angular velocities every partial velocity of a revolute tree is a vector that is
//! constant in one body's frame, so Kane's sums regroup by pairs of speeds: for an ancestor k of
//! body j (c the child of k on the path to j, Δ = θ_j − θ_k the sum of the joint angles between),
//! `M_kj = α cos Δ − β sin Δ` with `α = at_c·S'_j` and `β = at_c × S'_j` computed once, and the
//! centripetal inertia forces of that pair are `F_k += u_j² D`, `F_j −= u_k² D` with
//! `D = α sin Δ + β cos Δ` (see `Model::evaluate_absolute`).
//!
//! **The CPVA of the paper, eq. (7).** The rotor is body k = 0 (coordinate θ), pendulum i is body
//! j = i (coordinate φ_i) pivoted at `at_c = (R, 0)` on the rotor, with its first moment
//! `S'_j = m (L, 0)` in its own frame (m the pendulum mass, L its pivot-to-centre distance). Then
//! `α = R·mL = m R L`, `β = R × mL = 0` (pivot and centre of mass on one ray at φ = 0) and
//! `Δ = φ_i`, so
//! - `M_0i = α cos Δ = m R L cos φ_i`: the coupling `b cos φ_i` of eq. (7);
//! - `F_0 += u_i² D = m R L u_i² sin φ_i`: the rotor's `m_p R L u₂² sin φ` term (for N pendulums
//!   one per pendulum with m = m_p/N), which eq. (7) writes on the left as `−Σ b u_i² sin φ_i`;
//! - `F_i −= u_0² D = m R L u_1² sin φ_i`: the pendulum's centrifugal restoring term `b u1² sin φ_i`;
//! - `M_00 = I_A + Σ m R²` and `M_ii = I_B/N + m L²` are the constant diagonal (`diag_abs`).
//!
//! This form is chosen only when every joint is revolute (no fixed or prismatic joint): there the
//! angles of partial velocities are relative joint angles. Any other kind falls back to the
//! joint-rate recursion of [`super::rates`] with its result mapped to these speeds.

use super::{GROUND_PARENT, Model, NONE, Workspace};
use crate::model::loads::ForceFrame;
use crate::model::math::{Vec2, cross2, rotate_cs};
use crate::model::sincos::sin_cos_many;

impl Model {
    /// `Model::evaluate` for absolute angular velocities, in pair-coefficient form.
    ///
    /// Kane's sums regrouped by pairs of speeds: with u_k = ω_k, a body i below k has
    /// `ω_{i,k} = δ_ik` and `v_{i,k} = ẑ × R_k r_ik` with r_ik constant in body k's frame (the
    /// centre of mass offset for i = k, the joint offset `at_c` of k's child c towards i
    /// otherwise). So every term of `M_rs = Σ_i m_i v_{i,r}·v_{i,s} + I_i ω_{i,r} ω_{i,s}` is a
    /// constant vector pair turned by the relative angle of two bodies:
    ///
    /// - `M_kk` is constant (`diag_abs`), and for k an ancestor of j (Δ = θ_j − θ_k)
    ///   `M_kj = α cos Δ − β sin Δ`, with `α = at_c·S'_j`, `β = at_c × S'_j` precomputed
    ///   (S'_j: first moment of j's subtree as seen by u_j, constant in j's frame);
    /// - at u̇ = 0 the bias accelerations are purely centripetal, `a⁰_i = −Σ_l ω_l² R_l r_il`, so
    ///   the inertia forces `−Σ_i m_i a⁰_i·v_{i,r}` of the same pair are `±ω² ∂M_kj/∂θ_k`:
    ///   `F_k += ω_j² D`, `F_j −= ω_k² D` with `D = α sin Δ + β cos Δ`;
    /// - gravity adds `(R_k S'_k) × g` to F_k; a joint torque τ_j adds to F_j and subtracts from
    ///   F_parent (q̇_j = u_j − u_parent); a point force f at P on body b adds `(R_k r) × f` to
    ///   every F_k on b's path (r = P − o_b for k = b, `at_c` above).
    ///
    /// Δ is composed along the walk from the joint angles' sines and cosines, so each body costs
    /// one `sin_cos` (none for a root in its own frame) and each pair a few multiplications.
    ///
    /// NOTE: this replaced a composite-body recursion (forward pass of poses and centripetal
    /// accelerations, backward pass of subtree forces and moments): the same sums in fewer
    /// instructions (BENCHMARKS.md), because the accelerations, forces and moments about joint
    /// points are never formed.
    ///
    /// Kernel: the pair sums above in one walk per body; its length is those formulas'.
    #[inline(always)]
    pub(super) fn evaluate_absolute<const N: usize>(
        &self,
        ws: &mut Workspace,
        t: f64,
        q: &[f64],
        u: &[f64],
        forcing: bool,
    ) {
        let n = if N == 0 { self.n } else { N };
        let (q, u) = (&q[..n], &u[..n]);
        let (world, g) = (self.world, self.gravity);
        let gravity = world && g != Vec2::zeros();
        let oriented = gravity || !self.point_forces.is_empty();
        let nodes = &self.nodes[..n];
        let st = &mut ws.state[..n];
        let m = &mut ws.m[..n * n];
        let f = &mut ws.f[..n];
        let (pairs, mut pair) = (&self.pairs[..], 0);
        // NOTE: beyond the fixed-size instances (N = 0: many bodies) the joint angles' sines and
        // cosines are taken four at a time first (`sin_cos_many`, within an ulp of std's; one
        // libm call per body was the largest cost of a 32-pendulum rotor's right-hand side,
        // BENCHMARKS.md); the small instances keep std's, so their results do not move.
        let (sin, cos) = (&mut ws.sin[..n], &mut ws.cos[..n]);
        if N == 0 {
            sin_cos_many(q, sin, cos);
        }
        // NOTE: F's entry of the ancestor that the last bodies added to (a rotor, for its
        // pendulums) is accumulated in a register (`pk`, `pv`) rather than through memory, where
        // every pendulum's two additions were a store and reload on one serial chain (measured,
        // BENCHMARKS.md); the same operations in the same order. Bodies come after their parents.
        let (mut pk, mut pv) = (NONE, 0.0);
        for j in 0..n {
            let nd = &nodes[j];
            let root = nd.parent == GROUND_PARENT;
            let (js, jc) = if root && !world {
                (0.0, 1.0)
            } else if N == 0 {
                (sin[j], cos[j])
            } else {
                q[j].sin_cos()
            };
            // NOTE: the body's own orientation is only needed by gravity and point forces; the
            // pairs use relative angles (measured, BENCHMARKS.md).
            let (c, s) = if root || !oriented {
                (jc, js)
            } else {
                let p = &st[nd.parent];
                (p.c * jc - p.s * js, p.s * jc + p.c * js)
            };
            let b = &mut st[j];
            (b.c, b.s, b.jc, b.js) = (c, s, jc, js);
            m[j * n + j] = nd.diag_abs;
            let w = u[j];
            let mut fj = 0.0;
            if forcing {
                let qd = if root { w } else { w - u[nd.parent] };
                b.qdot = qd;
                let tau = -nd.k_spring * (q[j] - nd.q_free) - nd.c_joint * qd;
                fj = tau - nd.c_ground * w;
                if !root {
                    let p = nd.parent;
                    if pk != p {
                        if pk != NONE {
                            f[pk] = pv;
                        }
                        (pk, pv) = (p, f[p]);
                    }
                    pv -= tau;
                }
                if gravity {
                    fj += cross2(rotate_cs(c, s, nd.first_abs), g);
                }
            }
            // Ancestors k of j, nearest first, with (rc, rs) the cosine and sine of θ_j − θ_k.
            let (mut rc, mut rs, mut k) = (jc, js, nd.parent);
            while k != GROUND_PARENT {
                // NOTE: one pair per step of this walk, in the order `build` pushed them.
                let (alpha, beta) = pairs[pair];
                pair += 1;
                let v = alpha * rc - beta * rs;
                m[k * n + j] = v;
                m[j * n + k] = v;
                if forcing {
                    let d = alpha * rs + beta * rc;
                    if pk != k {
                        if pk != NONE {
                            f[pk] = pv;
                        }
                        (pk, pv) = (k, f[k]);
                    }
                    pv += w * w * d;
                    fj -= u[k] * u[k] * d;
                }
                let next = nodes[k].parent;
                if next != GROUND_PARENT {
                    let a = &st[k];
                    (rc, rs) = (a.jc * rc - a.js * rs, a.js * rc + a.jc * rs);
                }
                k = next;
            }
            if forcing {
                f[j] = fj;
            }
        }
        if pk != NONE {
            f[pk] = pv;
        }
        if !forcing {
            return;
        }
        for pfc in &self.point_forces {
            let b = &st[pfc.body];
            let force = match pfc.frame {
                ForceFrame::World => pfc.force,
                ForceFrame::Body => rotate_cs(b.c, b.s, pfc.force),
            };
            f[pfc.body] += cross2(rotate_cs(b.c, b.s, pfc.at), force);
            let (mut c, mut k) = (pfc.body, nodes[pfc.body].parent);
            while k != GROUND_PARENT {
                let a = &st[k];
                f[k] += cross2(rotate_cs(a.c, a.s, nodes[c].at), force);
                (c, k) = (k, nodes[k].parent);
            }
        }
        for jt in &self.torques {
            let tau = jt.excitation.torque(t);
            f[jt.joint] += tau;
            let p = nodes[jt.joint].parent;
            if p != GROUND_PARENT {
                f[p] -= tau;
            }
        }
    }

    /// The residual `r = M(q) u̇ − F(q, u, t)` with its exact derivatives `∂r/∂q` and `∂r/∂u`
    /// (row-major n × n), and M (row-major) into `m_out`, for absolute angular velocities
    /// without gravity or point forces: there every q-dependence is a pair term of
    /// `Model::evaluate_absolute`, `M_kj = α cos Δ − β sin Δ` and `D = α sin Δ + β cos Δ`, with
    /// `∂M_kj/∂Δ = −D`, `∂D/∂Δ = M_kj`, and Δ = θ_j − θ_k the sum of the joint angles on the path
    /// from k (exclusive) to j, so the derivatives cost one extra walk over the pairs instead of
    /// 2n (q) + 2n (u) central differences. Returns false, writing nothing, for the other
    /// cases (joint-rate speeds, gravity, point forces): difference
    /// [`super::Kane::mass_matrix_and_forcing_rows`] there. Excitation torques depend on t only.
    /// The couplings' exact derivatives are added unless suspended in `ws`.
    #[allow(clippy::too_many_arguments)]
    pub fn residual_jacobian(
        &self,
        ws: &mut Workspace,
        t: f64,
        q: &[f64],
        u: &[f64],
        udot: &[f64],
        r: &mut [f64],
        dr_dq: &mut [f64],
        dr_du: &mut [f64],
        m_out: &mut [f64],
    ) -> bool {
        if !self.has_residual_jacobian() {
            return false;
        }
        let n = self.n;
        self.evaluate(ws, t, q, u, true);
        let (m, f) = (&ws.m[..n * n], &ws.f[..n]);
        m_out[..n * n].copy_from_slice(m);
        for i in 0..n {
            let mut acc = -f[i];
            for j in 0..n {
                acc += m[i * n + j] * udot[j];
            }
            r[i] = acc;
        }
        let (dq, du) = (&mut dr_dq[..n * n], &mut dr_du[..n * n]);
        dq.fill(0.0);
        du.fill(0.0);
        // The walk's joints between k and j (j first).
        let path = &mut ws.walk;
        let (nodes, st, pairs) = (&self.nodes[..n], &ws.state[..n], &self.pairs[..]);
        let mut pair = 0;
        for j in 0..n {
            let nd = &nodes[j];
            let (w, root) = (u[j], nd.parent == GROUND_PARENT);
            // Spring and dampers: τ = −k (q_j − q₀) − c (u_j − u_p) acts +τ on j, −τ on p;
            // the ground damper −c_g u_j on j; r carries −F.
            dq[j * n + j] += nd.k_spring;
            du[j * n + j] += nd.c_joint + nd.c_ground;
            if !root {
                let p = nd.parent;
                dq[p * n + j] -= nd.k_spring;
                du[j * n + p] -= nd.c_joint;
                du[p * n + j] -= nd.c_joint;
                du[p * n + p] += nd.c_joint;
            }
            path.clear();
            path.push(j);
            let b = &st[j];
            let (mut rc, mut rs, mut k) = (b.jc, b.js, nd.parent);
            while k != GROUND_PARENT {
                let (alpha, beta) = pairs[pair];
                pair += 1;
                // M_kj as `evaluate` wrote it; D, its Δ-derivative up to sign.
                let v = m[k * n + j];
                let d = alpha * rs + beta * rc;
                // r_k = … + M_kj u̇_j − ω_j² D, r_j = … + M_kj u̇_k + ω_k² D.
                let (wk, gk, gj) = (u[k], -d * udot[j] - w * w * v, -d * udot[k] + u[k] * u[k] * v);
                for &l in path.iter() {
                    dq[k * n + l] += gk;
                    dq[j * n + l] += gj;
                }
                du[k * n + j] -= 2.0 * w * d;
                du[j * n + k] += 2.0 * wk * d;
                path.push(k);
                let next = nodes[k].parent;
                if next != GROUND_PARENT {
                    let a = &st[k];
                    (rc, rs) = (a.jc * rc - a.js * rs, a.js * rc + a.jc * rs);
                }
                k = next;
            }
        }
        if self.has_couplings() && !ws.couplings_suspended {
            self.coupling_jacobians(q, u, dr_dq, dr_du, -1.0);
        }
        true
    }
}
