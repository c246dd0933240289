//! The articulated-body route of the right-hand side: `M q̈ = F` solved in O(n) for any tree
//! without forming M, for both speed choices.
//!
//! The method is Featherstone's articulated-body algorithm (*Rigid Body Dynamics Algorithms*,
//! ch. 7, the recursion of §7.3 in the form of Table 7.1), written with planar spatial 3-vectors:
//! a motion is `(ω, v)` with v the velocity of the body point at a reference point, a force
//! `(n, f)` with n the moment about it, an inertia a symmetric 3 × 3 matrix. Every quantity of
//! body j is referred to its joint point o_j and expressed in the subtree's basis (the one the
//! forward pass uses), so a body's own inertia, bias force and joint column come from the
//! forward pass of the composite-body form ([`super::rates`]) as they are, and passing to the
//! parent is a shift by `d = o_j − o_p` only (eq. 2.25's X without its rotation).
//!
//! The accelerations that q̈ does not cause, and the applied forces, are Kane's bias terms at
//! u̇ = 0: with b_j the applied-minus-inertial force of body j at q̈ = 0, the joint equations are
//! `s_kᵀ Σ_{i below k} (I_i â_i − b_i) = τ_k` with â_i the acceleration q̈ causes. The
//! backward pass (children first) then carries the articulated inertia `Iᴬ` and the force `z`
//! the subtree needs besides `Iᴬ â` (eqs. 7.40–7.43 with p = −z):
//!
//! `U = Iᴬ s`, `D = sᵀ U`, `μ = τ + sᵀ z`, and the parent receives `Iᴬ − U Uᵀ/D` and `z − U μ/D`;
//!
//! and the forward pass (parents first) `q̈ = (μ − Uᵀ â_p)/D`, `â = â_p + s q̈` (eqs. 7.44–7.46,
//! the velocity-product term c already in b). A fixed joint passes its subtree's `Iᴬ` and z on
//! whole. A path joint's rollers (docs/design/paths.md, "Rollers") are a second rigid body moved by the
//! same coordinate with its own column: the joint's U, D and μ sum both bodies' terms, and the
//! parent receives both inertias.
//!
//! With absolute angular velocities, `q̇ = B u` with B constant, so `Bᵀ M B u̇ = Bᵀ F` is
//! `M q̈ = F` with `q̈ = B u̇`: the route takes the joint rates, solves for q̈ and returns
//! `u̇ = W q̈` (`u̇_k = q̈_k + u̇_p`, parents first). The couplings' torques act on their joint
//! rate, as in the joint-rate form.
//!
//! A geared mechanism's reduced M couples joints across branches (`Tᵀ M T`, [`super::reduce`]):
//! no tree recursion applies, and it keeps the formed M (dense LDLᵀ). The route costs a constant
//! per body, more than forming M for a shallow tree (the pair form's few ancestors per speed,
//! the tree's factorisation linear in n): it is chosen at build only for more than six speeds
//! and where the factorisation's work per speed exceeds a threshold measured on chains and on a
//! rotor carrying pendulums (`Model::articulated_choice`, BENCHMARKS.md), so chains and deep
//! trees take it and a rotor carrying many absorbers keeps the formed M along its tree.

use super::{GROUND_PARENT, Model, NO_COORD, NONE, PIVOT_TOL, Workspace};
use crate::error::EngineError;
use crate::model::math::{Vec2, cross2, perp};
use crate::model::speeds::Speeds;

/// The factorisation work per speed (see [`Model::articulated_choice`]) above which the
/// articulated-body route is faster than forming M and solving it: between the 8-link chain's
/// 10.6 (the formed M faster) and the 16-link chain's 43 (the articulated-body route faster).
const DEEP: f64 = 20.0;

/// The articulated-body quantities of one body, about its joint point, in the subtree's basis.
#[derive(Debug, Clone, Copy, Default)]
pub(super) struct Articulated {
    /// The articulated inertia `Iᴬ`, symmetric: entries (ω,ω) kg·m², (ω,x) and (ω,y) kg·m,
    /// (x,x), (x,y) and (y,y) kg.
    ww: f64,
    wx: f64,
    wy: f64,
    xx: f64,
    xy: f64,
    yy: f64,
    /// The force z (moment about the joint point, force) that the subtree needs besides `Iᴬ â`.
    zn: f64,
    zf: Vec2,
    /// `U = Iᴬ s` of the body's joint, `1/D` and `μ`.
    un: f64,
    uf: Vec2,
    d_inv: f64,
    mu: f64,
    /// The acceleration q̈ causes (angular, and of the joint point), forward pass.
    alpha: f64,
    acc: Vec2,
}

impl Articulated {
    /// Adds `other` (an inertia and a force at a point d from this one's point) shifted here.
    #[inline(always)]
    fn add_shifted(&mut self, o: &Articulated, d: Vec2) {
        // Xᵀ Iᴬ X with X the motion shift (ω, v) ↦ (ω, v + ω ẑ × d): only the row of ω changes.
        let wx = o.wx - d.y * o.xx + d.x * o.xy;
        let wy = o.wy - d.y * o.xy + d.x * o.yy;
        self.ww += o.ww - d.y * (o.wx + wx) + d.x * (o.wy + wy);
        self.wx += wx;
        self.wy += wy;
        self.xx += o.xx;
        self.xy += o.xy;
        self.yy += o.yy;
        self.zn += o.zn + cross2(d, o.zf);
        self.zf += o.zf;
    }

    /// `Iᴬ (w, v)`: the (moment, force) of a motion.
    #[inline(always)]
    fn times(&self, w: f64, v: Vec2) -> (f64, Vec2) {
        (
            self.ww * w + self.wx * v.x + self.wy * v.y,
            Vec2::new(self.wx * w + self.xx * v.x + self.xy * v.y, self.wy * w + self.xy * v.x + self.yy * v.y),
        )
    }
}

impl Model {
    /// True when the right-hand side takes the articulated-body route (chosen at build, see the
    /// module doc): a tree of more than [`super::SMALL`] speeds without geared couplings, deep
    /// enough that forming and factorising M costs more. Forming M walks each speed's ancestors
    /// and the cheaper factorisation costs `min(Σ_k (depth_k + 1)², n³/6)`; the articulated-body
    /// route costs a constant per body, about that of a factorisation work of [`DEEP`] per speed
    /// (measured on chains and on a rotor carrying pendulums, BENCHMARKS.md).
    pub(super) fn articulated_choice(&self) -> bool {
        let n = self.n;
        if n <= super::SMALL || !self.articulated_applies() {
            return false;
        }
        let above = self.speed_tree();
        let mut work = 0.0f64;
        for k in 0..n {
            let (mut depth, mut a) = (1.0, above[k]);
            while a != NONE {
                depth += 1.0;
                a = above[a];
            }
            work += depth * depth;
        }
        let dense = (n * n * n) as f64 / 6.0;
        work.min(dense) > DEEP * n as f64
    }

    /// True when the articulated-body route can serve this model (whether or not it is the
    /// faster): no geared couplings, at most one roller set per path joint.
    pub(super) fn articulated_applies(&self) -> bool {
        self.geared.is_none() && self.roller_of.is_some()
    }

    /// Per body, the index of the rollers its path joint moves (`NONE` for none), when every
    /// path joint has at most one set.
    pub(super) fn rollers_by_body(&self) -> Option<Vec<usize>> {
        let mut out = vec![NONE; self.nb];
        for (i, sat) in self.rollers.iter().enumerate() {
            let j = self.joint_of[sat.coord];
            if out[j] != NONE {
                return None;
            }
            out[j] = i;
        }
        Some(out)
    }

    /// [`super::Kane::rhs`] by the articulated-body algorithm (see the module doc).
    ///
    /// Kernel: Featherstone's three passes (velocities out, articulated inertias in, accelerations
    /// out) over one workspace, as the algorithm is written; its length is the algorithm's.
    #[inline(never)]
    pub(super) fn rhs_articulated(
        &self,
        ws: &mut Workspace,
        t: f64,
        x: &[f64],
        xdot: &mut [f64],
    ) -> Result<(), EngineError> {
        let (n, nb) = (self.n, self.nb);
        let (q, u) = x.split_at(n);
        let (qd_out, ud) = xdot.split_at_mut(n);
        // The joint rates: u itself, or `q̇ = B u` for absolute speeds.
        let mut rates = std::mem::take(&mut ws.qdot);
        let absolute = self.speeds == Speeds::AbsoluteAngularVelocities;
        if absolute {
            self.speeds.qdot(&self.speed_parent, u, &mut rates);
        } else {
            rates.copy_from_slice(u);
        }
        self.forward_rates::<0>(ws, t, q, &rates, true);
        if !ws.couplings_suspended {
            for c in &self.couplings {
                ws.state[self.joint_of[c.coord]].tau += c.law.torque(q[c.coord], rates[c.coord]);
            }
        }
        qd_out.copy_from_slice(&rates);
        ws.qdot = rates;
        let roller_of = self.roller_of.as_deref().unwrap_or(&[]);
        let nodes = &self.nodes[..nb];
        let (st, ab) = (&ws.state[..nb], &mut ws.aba[..nb]);
        // Each body's own inertia and bias force about its joint point.
        for ((a, b), nd) in ab.iter_mut().zip(st).zip(nodes) {
            let s = b.first;
            *a = Articulated {
                ww: b.inertia,
                wx: -s.y,
                wy: s.x,
                xx: nd.mass,
                xy: 0.0,
                yy: nd.mass,
                zn: b.moment,
                zf: b.force,
                ..Articulated::default()
            };
        }
        // Backward pass, children first.
        let (mut d_max, mut d_min, mut k_min) = (0.0f64, f64::INFINITY, 0);
        for j in (0..nb).rev() {
            let (nd, b) = (&nodes[j], &st[j]);
            let mut a = ab[j];
            if nd.coord != NO_COORD {
                let (w, v) = (b.col_w, b.col_v);
                // NOTE: a revolute joint's column is (1, 0): U is Iᴬ's first column, D its corner.
                let (mut un, mut uf, mut mu, mut d) = if nd.kind.rotates() {
                    (a.ww, Vec2::new(a.wx, a.wy), b.tau + a.zn, a.ww)
                } else {
                    let (un, uf) = a.times(w, v);
                    (un, uf, b.tau + w * a.zn + v.dot(&a.zf), w * un + v.dot(&uf))
                };
                if roller_of.get(j).is_some_and(|&r| r != NONE) {
                    // The rollers about o_j: their inertia, column and bias force moved there.
                    let sat = &self.rollers[roller_of[j]];
                    let rt = self.roller_terms(sat, st, q, &ws.qdot, true);
                    let e = rt.r - b.origin;
                    let (m, s) = (sat.mass, sat.mass * e);
                    let roller = Articulated {
                        ww: sat.i_com + m * e.norm_squared(),
                        wx: -s.y,
                        wy: s.x,
                        xx: m,
                        xy: 0.0,
                        yy: m,
                        zn: rt.moment + cross2(e, rt.force),
                        zf: rt.force,
                        ..Articulated::default()
                    };
                    let vr = rt.col_v - rt.col_w * perp(e);
                    let (rn, rf) = roller.times(rt.col_w, vr);
                    un += rn;
                    uf += rf;
                    d += rt.col_w * rn + vr.dot(&rf);
                    mu += rt.col_w * roller.zn + vr.dot(&roller.zf);
                    a.add_shifted(&roller, Vec2::zeros());
                }
                if d.is_nan() {
                    return Err(self.pivot_error(nd.coord, d));
                }
                if d < d_min {
                    (d_min, k_min) = (d, nd.coord);
                }
                d_max = d_max.max(d);
                let d_inv = 1.0 / d;
                let (sn, sf) = (un * d_inv, uf * d_inv);
                // Iᴬ − U Uᵀ/D and z − U μ/D.
                a.ww -= un * sn;
                a.wx -= un * sf.x;
                a.wy -= un * sf.y;
                a.xx -= uf.x * sf.x;
                a.xy -= uf.x * sf.y;
                a.yy -= uf.y * sf.y;
                a.zn -= sn * mu;
                a.zf -= sf * mu;
                (a.un, a.uf, a.d_inv, a.mu) = (un, uf, d_inv, mu);
                ab[j] = a;
            }
            if nd.parent != GROUND_PARENT {
                let (done, rest) = ab.split_at_mut(j);
                done[nd.parent].add_shifted(&a, b.d);
                rest[0] = a;
            }
        }
        // The LDLᵀ's test on its pivots, here on the D's.
        if d_min <= PIVOT_TOL * d_max {
            return Err(self.pivot_error(k_min, d_min));
        }
        // Forward pass, parents first.
        for j in 0..nb {
            let (nd, b) = (&nodes[j], &st[j]);
            let (alpha, acc) = if nd.parent == GROUND_PARENT {
                (0.0, Vec2::zeros())
            } else {
                let p = &ab[nd.parent];
                (p.alpha, p.acc + p.alpha * perp(b.d))
            };
            let a = &mut ab[j];
            (a.alpha, a.acc) = (alpha, acc);
            if nd.coord != NO_COORD {
                let qdd = (a.mu - a.un * alpha - a.uf.dot(&acc)) * a.d_inv;
                ud[nd.coord] = qdd;
                a.alpha += b.col_w * qdd;
                a.acc += b.col_v * qdd;
            }
        }
        if absolute {
            // u̇ = W q̈: each speed's parent comes first.
            for k in 0..n {
                if let Some(p) = self.speed_parent[k] {
                    ud[k] += ud[p];
                }
            }
        }
        Ok(())
    }
}
