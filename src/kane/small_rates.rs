//! The right-hand side of the composite-body form ([`super::rates`]) for small trees, in
//! fixed-size storage: a tree of at most [`SMALL`] speeds of any joint kind with a coordinate
//! (revolute, prismatic, path; no fixed joint) and no point forces, with absolute angular
//! velocities mapped from the joint rates (`Form::MappedRates`: `M ← Bᵀ M B`, `F ← Bᵀ F`,
//! B = W⁻¹). This is where a rotor carrying path-joint absorbers goes; a rotor carrying exactly
//! one, with absolute speeds or joint rates, takes the pair form of [`super::path_pair`].
//!
//! The method is `Model::evaluate_rates`'s, term for term and in the same order (a forward pass of
//! poses, rates, bias accelerations and motion columns; a backward pass of composite sums about
//! the joint points giving M_kl and F_k), then `Model::map_rates_to_speeds` and `Model::factor_solve`,
//! so the results are those of the general path to the bit (up to the sign of a zero) whenever
//! the joint torques are listed in joint order (as for [`super::small`]). What differs is where
//! the data live, when the joints are asked for their motion, and which exact no-ops are skipped:
//!
//! - every joint's `JointMotion` is evaluated first, in one loop, then the excitation torques,
//!   before any other arithmetic: the path's closed form heads the longest dependency chain, and
//!   nothing is live across the calls into libm;
//! - a path joint's mounting rotation (`cos γ`, `sin γ`) is constant and computed here once
//!   (skipped when γ = 0), instead of once per call, and handed to the joint kind's
//!   `motion_mounted` (the one place a joint's motion is written);
//! - a child of a root in its own frame (the basis) skips the rotations by its parent's exact
//!   (1, 0) and the parent's exactly zero accelerations;
//! - the per-body records are local arrays of the literal length N indexed by literal indices
//!   only, the tree's topology entering as tests of constant data (parents, ancestors, speed
//!   parents), so the compiler keeps them in registers and unrolls every loop, the mapping and
//!   the LDLᵀ included.
//!
//! NOTE: the form is the general one made fixed-size rather than a new regrouping: besides the
//! mount rotation above, the joint interface stays the only thing it knows about a path
//! (docs/design/kane.md, "Fast path for path joints"), and equality with the general path is by
//! construction, not by a second derivation.
//!
//! The exception is the commonest tree, a rotor carrying one path absorber about its axis: it
//! takes the pair form of [`super::path_pair`], which hands every failure back to this form.

use super::{GROUND_PARENT, Model, NONE, Node, PIVOT_TOL, SMALL, SmallRhs};
use crate::error::EngineError;
use crate::model::joint::{JointMotion, PathJoint};
use crate::model::math::{Vec2, cross2, perp, rotate_cs};
use crate::model::path::PolarPath;

/// Sets an engine's fixed-size instance to the composite-body one given with its data; passed
/// in by `small.rs`, which owns that instance's type (so this module does not import it back).
pub(super) type Install = dyn Fn(&mut Model, SmallRhs, Packed);

/// The constant data of the fixed-size composite-body path, packed once at construction.
#[derive(Debug, Clone, Default)]
pub(super) struct Packed {
    /// Per body: its parent body, `NONE` for a root.
    pub(super) parent: [usize; SMALL],
    /// `ancestor[l][j]`: l is a proper ancestor of j.
    ancestor: [[bool; SMALL]; SMALL],
    /// Per body: a revolute root expressed in its own frame (the basis), whose motion is the
    /// identity and needs no trigonometry.
    pub(super) basis: [bool; SMALL],
    /// Per body: a revolute joint (its M and F terms take the revolute shortcuts of the general
    /// form).
    revolute: [bool; SMALL],
    /// Per body: cosine and sine of a path joint's mounting angle, `None` when it is zero (then
    /// the rotation by it, `(1·x − 0·y, 0·x + 1·y)`, is the identity up to the sign of a zero).
    mount: [Option<(f64, f64)>; SMALL],
    /// Per body: its parent is a `basis` root, whose cosine and sine are exactly 1 and 0, whose
    /// angular acceleration and origin acceleration are exactly zero at u̇ = 0: the rotations by
    /// the parent are the identity and the parent's acceleration terms vanish, up to the sign of
    /// a zero (the general form's `0 + 0·x − y` is `−y`).
    basis_parent: [bool; SMALL],
    /// Per speed: the speed subtracted in `q̇ = W⁻¹u` (`Model::speed_parent`), `NONE` without.
    pub(super) speed_parent: [usize; SMALL],
    /// Per speed: the index of its joint's applied torque in `Model::torques`, or `NONE`.
    pub(super) torque: [usize; SMALL],
    /// The constants of the rotor-and-absorber pair form, when the tree is one
    /// ([`super::path_pair`]).
    pub(super) pair: Option<PathPair>,
}

/// The constants of the pair form of a rotor carrying one path absorber
/// ([`Model::rhs_path_pair`](super::Model::rhs_path_pair), built in [`super::path_pair`]; kept
/// here, packed with the composite-body data it falls back on):
/// body 0 a revolute root in its own frame, body 1 on a path joint drawn about the rotor axis
/// (`at` = the rotor's joint point, (0, 0) in its frame) with its centre of mass at its frame
/// origin.
#[derive(Debug, Clone, Copy)]
pub(super) struct PathPair {
    /// The absorber's path, its constants prepared once.
    pub(super) path: PolarPath,
    /// The joint's travel limit, m (infinite without one): the joint kind's `limited` test.
    pub(super) limit: f64,
    /// `J₀ + I`: the rotor's inertia about its axis plus the absorber's centroidal inertia, kg·m².
    pub(super) j_sum: f64,
    /// The absorber's mass m, kg, and centroidal inertia I, kg·m².
    pub(super) mass: f64,
    pub(super) i_com: f64,
    /// Per body: joint spring k (N·m/rad, N/m) and its free coordinate, joint damper, ground
    /// damper (the rotor's and the absorber's absolute rotation).
    pub(super) k_spring: [f64; 2],
    pub(super) q_free: [f64; 2],
    pub(super) c_joint: [f64; 2],
    pub(super) c_ground: [f64; 2],
}

/// Packs the data of `kane` (already built, `Form::MappedRates` or `Form::Rates`; at most
/// `SMALL` speeds, one body per speed, no point forces: checked by the caller) when every
/// joint's torques allow it. The pair form is chosen on top of it by
/// [`super::path_pair::choose`].
pub(super) fn small(kane: &Model) -> Option<(SmallRhs, Packed)> {
    let n = kane.n;
    let rhs: SmallRhs = match n {
        1 => Model::rhs_small_rates::<1>,
        2 => Model::rhs_small_rates::<2>,
        3 => Model::rhs_small_rates::<3>,
        4 => Model::rhs_small_rates::<4>,
        5 => Model::rhs_small_rates::<5>,
        6 => Model::rhs_small_rates::<6>,
        _ => return None,
    };
    let mut p = Packed {
        parent: [NONE; SMALL],
        speed_parent: [NONE; SMALL],
        torque: [NONE; SMALL],
        mount: [None; SMALL],
        ..Packed::default()
    };
    for (j, nd) in kane.nodes[..n].iter().enumerate() {
        // One body per speed: coordinate j is joint j's.
        if nd.coord != j {
            return None;
        }
        let root = nd.parent == GROUND_PARENT;
        p.parent[j] = if root { NONE } else { nd.parent };
        let mut a = nd.parent;
        while a != GROUND_PARENT {
            p.ancestor[a][j] = true;
            a = kane.nodes[a].parent;
        }
        p.basis[j] = root && !kane.world && nd.kind.rotates();
        p.basis_parent[j] = !root && p.basis[nd.parent];
        p.revolute[j] = nd.kind.rotates();
        if let Some(PathJoint { mount, .. }) = nd.kind.path() {
            // The same `sin_cos` as the joint's general motion takes, once.
            let (ms, mc) = mount.sin_cos();
            p.mount[j] = (mount != 0.0).then_some((mc, ms));
        }
        p.speed_parent[j] = kane.speed_parent[j].unwrap_or(NONE);
    }
    // One torque per joint (a second one on the same joint takes the general path).
    for (i, jt) in kane.torques.iter().enumerate() {
        if jt.joint >= n || p.torque[jt.joint] != NONE {
            return None;
        }
        p.torque[jt.joint] = i;
    }
    Some((rhs, p))
}

/// The motion of body `nd`'s joint at `q`, with a path's mounting rotation prepared once
/// (`Packed::mount`; see the module doc).
#[inline(always)]
fn motion(nd: &Node, mount: Option<(f64, f64)>, q: f64) -> JointMotion {
    nd.kind.motion_mounted(nd.at, q, mount)
}

impl Model {
    /// [`Kane::rhs`](super::Kane::rhs) by the fixed-size composite-body path for `N` speeds (`N = self.n ≤ SMALL`,
    /// `self.small` set by [`small`]; the caller has checked the lengths of `x` and `xdot`).
    ///
    /// Kernel: one pass of Kane's composite-body sums and the LDLᵀ solve in local arrays; split
    /// into calls, the arrays would leave registers and the literal-N unrolling would stop.
    ///
    /// NOTE: the structure of [`super::small`]'s `rhs_small` (local arrays of the literal length
    /// N, literal indices only, topology as tests of constant data, libm first, out of line and
    /// called through `Small::rhs`) applied to `evaluate_rates`; its figures are in
    /// BENCHMARKS.md.
    #[inline(never)]
    pub(super) fn rhs_small_rates<const N: usize>(
        &self,
        t: f64,
        x: &[f64],
        xdot: &mut [f64],
    ) -> Result<(), EngineError> {
        let s = &self.small.as_ref().expect("the fixed-size path is chosen with its data").rates;
        let nodes = &self.nodes[..N];
        let (q, u) = (&x[..N], &x[N..2 * N]);
        let (qd, ud) = xdot.split_at_mut(N);
        let (qd, ud) = (&mut qd[..N], &mut ud[..N]);
        let g = self.gravity;
        // Everything that calls out (excitations, joint motions) first.
        let mut mo = [JointMotion { omega: 1.0, ..JointMotion::still(Vec2::zeros()) }; N];
        for (j, mo) in mo.iter_mut().enumerate() {
            if s.basis[j] {
                mo.origin = nodes[j].at;
            } else {
                *mo = motion(&nodes[j], s.mount[j], q[j]);
            }
        }
        let mut exc = [0.0; N];
        for (j, exc) in exc.iter_mut().enumerate() {
            if s.torque[j] != NONE {
                *exc = self.torques[s.torque[j]].excitation.torque(t);
            }
        }
        // q̇ = W⁻¹u: the joint rates the composite-body form runs on.
        let mut rate = [0.0; N];
        for j in 0..N {
            let mut up = 0.0;
            for p in 0..j {
                if s.speed_parent[j] == p {
                    up = u[p];
                }
            }
            rate[j] = u[j] - up;
            qd[j] = rate[j];
        }
        // Forward pass, parents first (`evaluate_rates`, term for term).
        let (mut c, mut sn) = ([1.0; N], [0.0; N]);
        let (mut origin, mut d) = ([Vec2::zeros(); N], [Vec2::zeros(); N]);
        let (mut omega, mut alpha, mut acc_o) = ([0.0; N], [0.0; N], [Vec2::zeros(); N]);
        let (mut col_w, mut col_v) = ([0.0; N], [Vec2::zeros(); N]);
        let (mut first, mut inertia) = ([Vec2::zeros(); N], [0.0; N]);
        let (mut force, mut moment, mut tau) = ([Vec2::zeros(); N], [0.0; N], [0.0; N]);
        for j in 0..N {
            let (nd, mo) = (&nodes[j], &mo[j]);
            let (mut pc, mut ps, mut w_p, mut alpha_p, mut acc_p) = (1.0, 0.0, 0.0, 0.0, Vec2::zeros());
            let basis_parent = s.basis_parent[j];
            origin[j] = mo.origin;
            for p in 0..j {
                if s.parent[j] == p {
                    d[j] = if basis_parent { mo.origin } else { rotate_cs(c[p], sn[p], mo.origin) };
                    origin[j] = origin[p] + d[j];
                    (pc, ps, w_p, alpha_p, acc_p) = (c[p], sn[p], omega[p], alpha[p], acc_o[p]);
                }
            }
            let turn = |v: Vec2| if basis_parent { v } else { rotate_cs(pc, ps, v) };
            (c[j], sn[j]) =
                if basis_parent { (mo.cos, mo.sin) } else { (pc * mo.cos - ps * mo.sin, ps * mo.cos + pc * mo.sin) };
            col_w[j] = mo.omega;
            col_v[j] = turn(mo.velocity);
            let arm = rotate_cs(c[j], sn[j], nd.com_local);
            first[j] = nd.mass * arm;
            inertia[j] = nd.j_own;
            let qdj = rate[j];
            omega[j] = w_p + mo.omega * qdj;
            alpha[j] = if basis_parent { mo.bias_alpha * qdj * qdj } else { alpha_p + mo.bias_alpha * qdj * qdj };
            let v_rel = col_v[j] * qdj;
            let transport =
                if basis_parent { -(w_p * w_p * d[j]) } else { acc_p + alpha_p * perp(d[j]) - w_p * w_p * d[j] };
            acc_o[j] = transport + 2.0 * w_p * perp(v_rel) + turn(mo.bias_acc) * (qdj * qdj);
            let acc_c = acc_o[j] + alpha[j] * perp(arm) - omega[j] * omega[j] * arm;
            let fi = nd.mass * (g - acc_c);
            force[j] = fi;
            moment[j] = cross2(arm, fi) - nd.i_com * alpha[j] - nd.c_ground * omega[j];
            tau[j] = -nd.k_spring * (q[j] - nd.q_free) - nd.c_joint * qdj;
            if s.torque[j] != NONE {
                tau[j] += exc[j];
            }
        }
        // Backward pass, children first: composite sums, rows of M and entries of F.
        let mut m = [[0.0; N]; N];
        let mut f = [0.0; N];
        for j in (0..N).rev() {
            let mass = nodes[j].subtree_mass;
            let (w, v) = (col_w[j], col_v[j]);
            if s.revolute[j] {
                f[j] = moment[j] + tau[j];
                m[j][j] = inertia[j];
            } else {
                f[j] = w * moment[j] + v.dot(&force[j]) + tau[j];
                m[j][j] = mass * v.norm_squared() + 2.0 * w * v.dot(&perp(first[j])) + w * w * inertia[j];
            }
            for l in (0..j).rev() {
                if !s.ancestor[l][j] {
                    continue;
                }
                let dl = origin[j] - origin[l];
                let val = if s.revolute[j] && s.revolute[l] {
                    inertia[j] + first[j].dot(&dl)
                } else {
                    mass * v.dot(&col_v[l])
                        + col_w[l] * v.dot(&perp(first[j] + mass * dl))
                        + w * perp(first[j]).dot(&col_v[l])
                        + w * col_w[l] * (inertia[j] + first[j].dot(&dl))
                };
                m[j][l] = val;
                m[l][j] = val;
            }
            for p in 0..j {
                if s.parent[j] == p {
                    let dj = d[j];
                    force[p] += force[j];
                    moment[p] += moment[j] + cross2(dj, force[j]);
                    inertia[p] += inertia[j] + 2.0 * dj.dot(&first[j]) + mass * dj.norm_squared();
                    first[p] += first[j] + mass * dj;
                }
            }
        }
        // To the speeds (`map_rates_to_speeds`): columns, then rows and F, then the mirror.
        for k in 0..N {
            for p in 0..k {
                if s.speed_parent[k] == p {
                    for r in 0..N {
                        m[r][p] -= m[r][k];
                    }
                }
            }
        }
        for k in 0..N {
            for p in 0..k {
                if s.speed_parent[k] == p {
                    for cc in 0..N {
                        m[p][cc] -= m[k][cc];
                    }
                    f[p] -= f[k];
                }
            }
        }
        for r in 0..N {
            for cc in 0..r {
                m[cc][r] = m[r][cc];
            }
        }
        // `factor_solve`: the pivot threshold relative to the largest diagonal entry, and the
        // first pivot tested like the others.
        let mut scale = 0.0f64;
        for (i, row) in m.iter().enumerate() {
            scale = scale.max(row[i].abs());
        }
        let pivot_min = PIVOT_TOL * scale;
        let d0 = m[0][0];
        let solved = if d0.is_nan() || d0 <= pivot_min {
            Err(self.pivot_error(0, d0))
        } else {
            self.ldlt_small::<N>(&m, &f, 1.0 / d0, pivot_min, ud)
        };
        solved.map_err(|e| self.out_of_travel(e, q))
    }

    /// A non-finite evaluation is a path joint beyond its end when one is (see `rhs_general`).
    #[cold]
    #[inline(never)]
    fn out_of_travel(&self, e: EngineError, q: &[f64]) -> EngineError {
        match e {
            EngineError::NonFinite { .. } => self.mech.path_out_of_travel(q).unwrap_or(e),
            e => e,
        }
    }
}
